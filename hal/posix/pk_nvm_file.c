/*
 * pk_nvm_file.c — a non-volatile store in a file (see pk_nvm_file.h).
 */
#define _XOPEN_SOURCE 700
#include "pk_nvm_file.h"

#include <errno.h>
#include <fcntl.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>
#include "hal.h"

int pk_nvm_file_open(struct pk_nvm_file *f, const char *path, uint32_t size)
{
    f->fd = -1;
    f->size = size;
    int fd = open(path, O_RDWR | O_CREAT | O_CLOEXEC, 0644);
    if (fd < 0)
        return -errno;
    struct stat st;
    if (fstat(fd, &st) != 0) {
        int e = errno;
        close(fd);
        return -e;
    }
    /* new or short: the missing part reads as an erased EEPROM (0xFF) */
    uint8_t ff[256];
    memset(ff, 0xff, sizeof ff);
    for (off_t o = st.st_size; o < (off_t)size;) {
        size_t n = (size_t)((off_t)size - o) < sizeof ff ? (size_t)((off_t)size - o) : sizeof ff;
        ssize_t w = pwrite(fd, ff, n, o);
        if (w <= 0) {
            int e = w < 0 ? errno : EIO;
            close(fd);
            return -e;
        }
        o += w;
    }
    f->fd = fd;
    return 0;
}

uint32_t pk_nvm_file_size(void *ctx) { return ((struct pk_nvm_file *)ctx)->size; }

int pk_nvm_file_read(void *ctx, uint32_t off, uint8_t *buf, size_t len)
{
    struct pk_nvm_file *f = ctx;
    if (f->fd < 0 || off > f->size || len > f->size - off)
        return PK_HAL_EINVAL;
    size_t done = 0;
    while (done < len) {
        ssize_t r = pread(f->fd, buf + done, len - done, (off_t)off + (off_t)done);
        if (r < 0 && errno == EINTR)
            continue;
        if (r <= 0)
            return PK_HAL_EIO;
        done += (size_t)r;
    }
    return PK_HAL_OK;
}

int pk_nvm_file_write(void *ctx, uint32_t off, const uint8_t *buf, size_t len)
{
    struct pk_nvm_file *f = ctx;
    if (f->fd < 0 || off > f->size || len > f->size - off)
        return PK_HAL_EINVAL;
    size_t done = 0;
    while (done < len) {
        ssize_t w = pwrite(f->fd, buf + done, len - done, (off_t)off + (off_t)done);
        if (w < 0 && errno == EINTR)
            continue;
        if (w <= 0)
            return PK_HAL_EIO;
        done += (size_t)w;
    }
    return fdatasync(f->fd) == 0 ? PK_HAL_OK : PK_HAL_EIO;
}

void pk_nvm_file_close(struct pk_nvm_file *f)
{
    if (f->fd >= 0)
        close(f->fd);
    f->fd = -1;
}
