/*
 * th — the portable core of the test harness: bookkeeping and number
 * formatting without libc, so it links into a bare-metal image.
 */
#include "th.h"

static int th_case_failed; /* per-run scratch: reset by th_run for each case */

void th_print(const char *s) { th_write(s); }

void th_print_i64(int64_t v)
{
    char buf[24];
    int i = 23;
    uint64_t u = v < 0 ? (uint64_t)0 - (uint64_t)v : (uint64_t)v;
    buf[i] = '\0';
    do {
        buf[--i] = (char)('0' + (int)(u % 10u));
        u /= 10u;
    } while (u != 0u);
    if (v < 0)
        buf[--i] = '-';
    th_write(&buf[i]);
}

static void th_where(const char *file, int line)
{
    th_write("  FAIL ");
    th_write(file);
    th_write(":");
    th_print_i64(line);
    th_write(": ");
}

void th_fail(const char *file, int line, const char *msg)
{
    th_case_failed = 1;
    th_where(file, line);
    th_write(msg);
    th_write("\n");
}

int th_check(int cond, const char *file, int line, const char *expr)
{
    if (!cond)
        th_fail(file, line, expr);
    return cond;
}

int th_check_i64(int64_t a, int64_t b, const char *file, int line, const char *ea, const char *eb)
{
    if (a == b)
        return 1;
    th_case_failed = 1;
    th_where(file, line);
    th_write(ea);
    th_write(" == ");
    th_write(eb);
    th_write(" (");
    th_print_i64(a);
    th_write(" != ");
    th_print_i64(b);
    th_write(")\n");
    return 0;
}

int th_run(const struct th_case *cases, unsigned n)
{
    unsigned passed = 0, failed = 0;
    for (unsigned i = 0; i < n; i++) {
        th_case_failed = 0;
        cases[i].fn();
        if (th_case_failed) {
            failed++;
            th_write("not ok ");
        } else {
            passed++;
            th_write("ok ");
        }
        th_write(cases[i].name);
        th_write("\n");
    }
    th_print_i64(passed);
    th_write(" passed, ");
    th_print_i64(failed);
    th_write(" failed\n");
    return (int)failed;
}
