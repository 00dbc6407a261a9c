/*
 * pk_nvm_file.h — a non-volatile store in a file (host only): the HAL's
 * optional nvm_size / nvm_read / nvm_write members (hal.h) for POSIX boards
 * and `plotkin serve --eeprom FILE`, so Grbl settings, offsets and startup
 * lines survive a restart as they do in a board's EEPROM.
 *
 * The file is created (filled with 0xFF, like an erased EEPROM) or extended
 * to the size asked; writes go to the file at once (pwrite, then fdatasync,
 * so a power cut after a `$N=value` answer keeps it). Not for firmware/.
 */
#ifndef PLOTKIN_PK_NVM_FILE_H
#define PLOTKIN_PK_NVM_FILE_H

#include <stddef.h>
#include <stdint.h>

struct pk_nvm_file {
    int fd;          /**< -1 when closed */
    uint32_t size;
};

/** Open (or create) path as a store of size bytes. 0, or -errno. */
int pk_nvm_file_open(struct pk_nvm_file *f, const char *path, uint32_t size);

/** The HAL members (ctx = struct pk_nvm_file). PK_HAL_OK, PK_HAL_EINVAL out
 *  of range, PK_HAL_EIO on an I/O error. */
uint32_t pk_nvm_file_size(void *ctx);
int pk_nvm_file_read(void *ctx, uint32_t offset, uint8_t *buf, size_t len);
int pk_nvm_file_write(void *ctx, uint32_t offset, const uint8_t *buf, size_t len);

/** Close; safe to call twice. */
void pk_nvm_file_close(struct pk_nvm_file *f);

#endif
