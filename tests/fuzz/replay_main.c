/*
 * replay_main.c — run a fuzz target over saved inputs without libFuzzer.
 *
 * Built with the ordinary compiler (plain and ASan+UBSan) and linked with one
 * tests/fuzz/fuzz_*.c, it feeds every file named on the command line (or
 * found in a directory named there) to LLVMFuzzerTestOneInput once. So the
 * seed corpora and every regression input in tests/fuzz/corpus/ run in
 * `make test` on machines without clang. A broken invariant aborts the
 * process (the runner then reports the missing result line); otherwise the
 * last line is "N passed, 0 failed", one per input.
 */
#include "fuzz_common.h"

#include <dirent.h>
#include <string.h>
#include <sys/stat.h>

static unsigned passed;

static int replay_file(const char *path)
{
    FILE *f = fopen(path, "rb");
    if (f == NULL) {
        perror(path);
        return -1;
    }
    static uint8_t buf[1 << 20];
    size_t n = fread(buf, 1, sizeof buf, f);
    fclose(f);
    /* a private copy of exactly n bytes, so ASan sees any read past the end */
    uint8_t *copy = malloc(n ? n : 1);
    if (copy == NULL)
        return -1;
    memcpy(copy, buf, n);
    LLVMFuzzerTestOneInput(copy, n);
    free(copy);
    passed++;
    return 0;
}

static int cmp_str(const void *a, const void *b)
{
    return strcmp(*(const char *const *)a, *(const char *const *)b);
}

static int replay_path(const char *path)
{
    struct stat sb;
    if (stat(path, &sb) != 0) {
        perror(path);
        return -1;
    }
    if (!S_ISDIR(sb.st_mode))
        return replay_file(path);
    DIR *d = opendir(path);
    if (d == NULL) {
        perror(path);
        return -1;
    }
    char *names[8192];
    unsigned k = 0;
    struct dirent *e;
    while ((e = readdir(d)) != NULL && k < 8192u) {
        if (e->d_name[0] == '.')
            continue;
        size_t len = strlen(path) + strlen(e->d_name) + 2;
        names[k] = malloc(len);
        if (names[k] == NULL)
            break;
        snprintf(names[k], len, "%s/%s", path, e->d_name);
        k++;
    }
    closedir(d);
    qsort(names, k, sizeof names[0], cmp_str); /* same order every run */
    int rc = 0;
    for (unsigned i = 0; i < k; i++) {
        if (replay_file(names[i]) != 0)
            rc = -1;
        free(names[i]);
    }
    return rc;
}

int main(int argc, char **argv)
{
    int failed = 0;
    for (int i = 1; i < argc; i++)
        if (replay_path(argv[i]) != 0)
            failed++;
    printf("%u passed, %d failed\n", passed, failed);
    return failed ? 1 : 0;
}
