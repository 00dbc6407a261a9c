/*
 * pk_serve_port.h — the serial side of a Grbl server on a POSIX host: the
 * line a G-code sender talks to, shared by the simulator's `plotkin serve`
 * (host-sim/cmd_serve.c) and the Linux board's `plotkin-gpiod serve`
 * (hal/posix/board/plotkin_gpiod.c), so both behave the same to a sender.
 *
 * The line is either a real serial device (pk_serial_open: raw 8N1) or a
 * pseudo-terminal with an optional stable symlink (pk_serial_open_pty). The
 * pty survives client disconnects (pk_serial.h keeps our own slave fd open),
 * so a sender can disconnect and reconnect and nothing already accepted is
 * lost. On a pty the port counts the clients that have it open (inotify
 * IN_OPEN / IN_CLOSE on the slave's inode; our own slave fd was opened
 * before the watch) and drops output only once nobody has had the pty open
 * for a whole second: a sender that reconnects at once still gets the
 * answers to what it sent, a client connecting later does not start with
 * stale lines, and a client that is merely slow never loses a byte (a lost
 * `ok` would hang a character-counting sender). The events are read before
 * the line is, and a client's open is queued before anything it writes, so
 * its first answer is never dropped. When the last client closes the pty,
 * whatever it sent is still read (pk_serial's rx_allow), and once all of it
 * has been taken from the ring the pump says so (PK_SERVE_PORT_LEFT): the
 * engine then drops that client's unfinished line before a byte of the next
 * client is read (a half "G0 X1" never glued to the next "0 Y5"; Grbl boards
 * get the same from the reset a port open gives them).
 *
 * Bytes move between the fd and a struct pk_uart (whose realtime filter
 * claims Grbl's ? ! ~ Ctrl-X on arrival, out of band) by pk_serial_pump:
 * never blocking, never reading more than the 128-byte ring can take.
 *
 * Host only (libc, termios, Linux inotify). Single-threaded; one struct per
 * line, caller-owned.
 */
#ifndef PLOTKIN_PK_SERVE_PORT_H
#define PLOTKIN_PK_SERVE_PORT_H

#include <stdint.h>
#include <stdio.h>
#include "pk_serial.h"
#include "pk_uart.h"

struct pk_serve_port {
    struct pk_serial ser;         /**< the line (ser.path: device or pty slave) */
    int opens;                    /**< inotify fd watching the pty slave, or -1 */
    unsigned long clients;        /**< clients that have the pty open now */
    unsigned long connections;    /**< times a first client opened it */
    uint64_t alone_since_ns;      /**< private: CLOCK_MONOTONIC since no client; 0: has one */
    uint8_t is_device;            /**< 1: a serial device (no client tracking) */
    uint8_t draining;             /**< private: the last client left; its bytes are being read */
};

/**
 * Open the line: the device `device` at `baud` (raw 8N1) if device is not
 * NULL, else a pty (with the symlink `link` if not NULL). If the client
 * tracking cannot be set up on a pty, one line on `warn` (may be NULL) says
 * what that means, and the port works without it.
 * @return 0, or -errno (nothing stays open)
 * Calling context: MAIN.
 */
int pk_serve_port_open(struct pk_serve_port *p, const char *device, uint32_t baud,
                       const char *link, FILE *warn);

#define PK_SERVE_PORT_RX 1    /**< bytes arrived: wake the engine */
#define PK_SERVE_PORT_LEFT 2  /**< the last client left and all it sent has been taken
                                   from the ring: drop its unfinished line now
                                   (pk_grbl_drop_partial_line), before the engine reads on */

/**
 * Track the pty's clients (dropping output nobody has read for a second of
 * no client), then move bytes both ways (pk_serial_pump).
 * @return PK_SERVE_PORT_* bits (0: nothing happened), or -errno on an I/O
 *         error of the line (not EAGAIN/EINTR)
 * Calling context: MAIN, every turn of the server's loop.
 */
int pk_serve_port_pump(struct pk_serve_port *p, struct pk_uart *u);

/**
 * A server's signals: SIGINT and SIGTERM call on_stop (which should only set
 * a sig_atomic_t flag the loop reads), SIGPIPE is ignored (a vanished client
 * is an I/O result, never a kill). Calling context: MAIN, once.
 */
void pk_serve_port_signals(void (*on_stop)(int sig));

/** Close the line, remove the symlink, stop watching. Safe to call twice. */
void pk_serve_port_close(struct pk_serve_port *p);

#endif
