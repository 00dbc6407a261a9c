/*
 * pk_serial.h — POSIX serial backends of the UART shim (host only).
 *
 * Two ways to get a file descriptor that behaves like a serial line, and one
 * pump that moves bytes between it and a struct pk_uart (playing the part of
 * the RX/TX interrupts on a board):
 *   - pk_serial_open: a real device (/dev/ttyUSB0, /dev/serial0, ...) in raw
 *     mode (termios: no echo, no line editing, no CR/LF translation, 8N1,
 *     CLOCAL|CREAD, VMIN=0/VTIME=0) at a given baud rate, non-blocking.
 *   - pk_serial_open_pty: a pseudo-terminal for the simulator. Clients (G-code
 *     senders) open the slave path it prints; we keep our own slave fd open
 *     so that the master never sees a hang-up when no client is connected
 *     (otherwise poll() reports POLLHUP forever and read() fails with EIO),
 *     which is what lets `plotkin serve` keep running across disconnects.
 * No libserialport. Uses libc and termios; not for firmware/.
 */
#ifndef PLOTKIN_PK_SERIAL_H
#define PLOTKIN_PK_SERIAL_H

#include <stddef.h>
#include <stdint.h>
#include "pk_uart.h"

struct pk_serial {
    int fd;              /**< device or pty master, O_NONBLOCK */
    int slave_fd;        /**< pty: our own slave fd (kept open); -1 for a device */
    char path[128];      /**< device path, or the pty slave path */
    char link[256];      /**< symlink made by pk_serial_open_pty, or "" */
    uint64_t rx_bytes;   /**< bytes moved into the RX ring (or claimed as realtime) */
    uint64_t tx_bytes;   /**< bytes written to the fd */
    long rx_allow;       /**< < 0: read freely; else bytes pk_serial_pump may still read
                              (e.g. the bytes a client wrote before it went away) */
};

/**
 * Open a serial device in raw mode.
 * @param baud  one of the standard rates (9600 .. 4000000); 0 keeps the current one
 * @return 0, or -errno (ENOENT, EACCES, EINVAL for an unsupported baud, ...)
 */
int pk_serial_open(struct pk_serial *s, const char *path, uint32_t baud);

/**
 * Create a pseudo-terminal, put its slave in raw mode, keep a slave fd open.
 * @param link  if not NULL/empty, create (or replace) a symlink to the slave
 * @return 0, or -errno
 */
int pk_serial_open_pty(struct pk_serial *s, const char *link);

/**
 * Move bytes: read from the fd while the RX ring has room (each byte through
 * pk_uart_rx_push, so realtime bytes are claimed at once), and write what the
 * TX ring holds. Never blocks. Bytes the ring has no room for stay in the
 * kernel's buffer (flow control by not reading), so a pty loses nothing.
 * @return 0, or -errno on an I/O error other than EAGAIN/EINTR
 */
int pk_serial_pump(struct pk_serial *s, struct pk_uart *u);

/** Bytes the peer wrote that have not been read yet (FIONREAD), 0 on error. */
size_t pk_serial_pending(const struct pk_serial *s);

/**
 * pty only: bytes we wrote that no client has read yet (the slave's input
 * queue), or 0 for a device / on error.
 */
size_t pk_serial_unread(const struct pk_serial *s);

/** pty only: discard those bytes (e.g. answers queued while no client was
 *  connected, which a new client must not receive). */
void pk_serial_discard_unread(struct pk_serial *s);

/** Close the fds and remove the symlink. Safe to call twice. */
void pk_serial_close(struct pk_serial *s);

#endif
