/*
 * pk_serial.c — termios device and pseudo-terminal backends of the UART shim
 * (see pk_serial.h).
 */
#define _XOPEN_SOURCE 700
#include "pk_serial.h"

#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/ioctl.h>
#include <termios.h>
#include <unistd.h>

/* Raw mode by hand (cfmakeraw is a BSD extension). */
static void make_raw(struct termios *t)
{
    t->c_iflag &= (tcflag_t) ~(IGNBRK | BRKINT | PARMRK | ISTRIP | INLCR | IGNCR | ICRNL | IXON |
                               IXOFF | IXANY);
    t->c_oflag &= (tcflag_t)~OPOST;
    t->c_lflag &= (tcflag_t) ~(ECHO | ECHONL | ICANON | ISIG | IEXTEN);
    t->c_cflag &= (tcflag_t) ~(CSIZE | PARENB | CSTOPB);
    t->c_cflag |= CS8 | CLOCAL | CREAD;
    t->c_cc[VMIN] = 0;
    t->c_cc[VTIME] = 0;
}

static int baud_const(uint32_t baud, speed_t *out)
{
    static const struct { uint32_t b; speed_t s; } table[] = {
        { 9600, B9600 },     { 19200, B19200 },   { 38400, B38400 },   { 57600, B57600 },
        { 115200, B115200 }, { 230400, B230400 },
#ifdef B460800
        { 460800, B460800 }, { 500000, B500000 }, { 921600, B921600 }, { 1000000, B1000000 },
        { 2000000, B2000000 }, { 4000000, B4000000 },
#endif
    };
    for (size_t i = 0; i < sizeof table / sizeof table[0]; i++)
        if (table[i].b == baud) {
            *out = table[i].s;
            return 0;
        }
    return -EINVAL;
}

static void init_struct(struct pk_serial *s)
{
    memset(s, 0, sizeof *s);
    s->fd = -1;
    s->slave_fd = -1;
    s->rx_allow = -1;
}

int pk_serial_open(struct pk_serial *s, const char *path, uint32_t baud)
{
    init_struct(s);
    speed_t sp = 0;
    if (baud != 0 && baud_const(baud, &sp) != 0)
        return -EINVAL;
    int fd = open(path, O_RDWR | O_NOCTTY | O_NONBLOCK);
    if (fd < 0)
        return -errno;
    struct termios t;
    if (tcgetattr(fd, &t) != 0) {
        int e = errno;
        close(fd);
        return -e;
    }
    make_raw(&t);
    if (baud != 0 && (cfsetispeed(&t, sp) != 0 || cfsetospeed(&t, sp) != 0)) {
        close(fd);
        return -EINVAL;
    }
    if (tcsetattr(fd, TCSANOW, &t) != 0) {
        int e = errno;
        close(fd);
        return -e;
    }
    s->fd = fd;
    snprintf(s->path, sizeof s->path, "%s", path);
    return 0;
}

int pk_serial_open_pty(struct pk_serial *s, const char *link)
{
    init_struct(s);
    int m = posix_openpt(O_RDWR | O_NOCTTY);
    if (m < 0)
        return -errno;
    const char *name;
    if (grantpt(m) != 0 || unlockpt(m) != 0 || (name = ptsname(m)) == NULL) {
        int e = errno;
        close(m);
        return -e;
    }
    snprintf(s->path, sizeof s->path, "%s", name);
    int sl = open(s->path, O_RDWR | O_NOCTTY | O_NONBLOCK);
    if (sl < 0) {
        int e = errno;
        close(m);
        return -e;
    }
    struct termios t;
    if (tcgetattr(sl, &t) == 0) {
        make_raw(&t);
        tcsetattr(sl, TCSANOW, &t);
    }
    int fl = fcntl(m, F_GETFL);
    if (fl < 0 || fcntl(m, F_SETFL, fl | O_NONBLOCK) != 0) {
        int e = errno;
        close(sl);
        close(m);
        return -e;
    }
    s->fd = m;
    s->slave_fd = sl;
    if (link != NULL && link[0] != '\0') {
        snprintf(s->link, sizeof s->link, "%s", link);
        unlink(link);
        if (symlink(s->path, link) != 0) {
            int e = errno;
            s->link[0] = '\0';
            pk_serial_close(s);
            return -e;
        }
    }
    return 0;
}

int pk_serial_pump(struct pk_serial *s, struct pk_uart *u)
{
    if (s->fd < 0)
        return -EBADF;
    /* Receive: never more than the ring can take, so nothing is dropped
     * (realtime bytes are claimed by the filter and take no room). */
    for (;;) {
        size_t room = pk_uart_rx_space(u);
        if (s->rx_allow >= 0 && (size_t)s->rx_allow < room)
            room = (size_t)s->rx_allow;
        if (room == 0)
            break;
        uint8_t buf[PK_UART_RX_SIZE];
        ssize_t n = read(s->fd, buf, room);
        if (n < 0) {
            if (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR)
                break;
            if (errno == EIO && s->slave_fd >= 0)
                break; /* pty without any slave: cannot happen while we hold one */
            return -errno;
        }
        if (n == 0)
            break;
        for (ssize_t i = 0; i < n; i++)
            pk_uart_rx_push(u, buf[i]);
        s->rx_bytes += (uint64_t)n;
        if (s->rx_allow > 0)
            s->rx_allow -= (long)n;
    }
    /* Transmit: write what the kernel takes; keep the rest in our hands.
     * Peek first, consume only what was written. */
    for (;;) {
        uint8_t buf[PK_UART_TX_SIZE];
        uint8_t t = atomic_load_explicit(&u->tx_tail, memory_order_relaxed);
        uint8_t h = atomic_load_explicit(&u->tx_head, memory_order_acquire);
        size_t n = 0;
        for (uint8_t i = t; i != h && n < sizeof buf; i++)
            buf[n++] = u->tx[i & (PK_UART_TX_SIZE - 1)];
        if (n == 0)
            break;
        ssize_t w = write(s->fd, buf, n);
        if (w < 0) {
            if (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR)
                break;
            return -errno;
        }
        pk_uart_tx_pop(u, buf, (size_t)w);
        s->tx_bytes += (uint64_t)w;
        if ((size_t)w < n)
            break;
    }
    return 0;
}

size_t pk_serial_pending(const struct pk_serial *s)
{
    int n = 0;
    if (s->fd < 0 || ioctl(s->fd, FIONREAD, &n) != 0 || n < 0)
        return 0;
    return (size_t)n;
}

size_t pk_serial_unread(const struct pk_serial *s)
{
    int n = 0;
    if (s->slave_fd < 0 || ioctl(s->slave_fd, FIONREAD, &n) != 0 || n < 0)
        return 0;
    return (size_t)n;
}

void pk_serial_discard_unread(struct pk_serial *s)
{
    if (s->slave_fd >= 0)
        tcflush(s->slave_fd, TCIFLUSH);
}

void pk_serial_close(struct pk_serial *s)
{
    if (s->link[0] != '\0') {
        unlink(s->link);
        s->link[0] = '\0';
    }
    if (s->slave_fd >= 0)
        close(s->slave_fd);
    if (s->fd >= 0)
        close(s->fd);
    s->fd = -1;
    s->slave_fd = -1;
}
