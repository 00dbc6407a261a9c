/*
 * pk_serve_port.c — a Grbl server's serial line with client tracking (see
 * pk_serve_port.h).
 */
#define _XOPEN_SOURCE 700
#include "pk_serve_port.h"

#include <errno.h>
#include <signal.h>
#include <string.h>
#include <sys/inotify.h>
#include <time.h>
#include <unistd.h>

static uint64_t mono_ns(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (uint64_t)ts.tv_sec * 1000000000ull + (uint64_t)ts.tv_nsec;
}

int pk_serve_port_open(struct pk_serve_port *p, const char *device, uint32_t baud,
                       const char *link, FILE *warn)
{
    memset(p, 0, sizeof *p);
    p->opens = -1;
    p->is_device = device != NULL;
    int rc = device ? pk_serial_open(&p->ser, device, baud) : pk_serial_open_pty(&p->ser, link);
    if (rc != 0)
        return rc;
    if (device)
        return 0;
    /* A client opening the slave is what makes unread output stale. */
    p->opens = inotify_init1(IN_NONBLOCK | IN_CLOEXEC);
    if (p->opens >= 0 && inotify_add_watch(p->opens, p->ser.path, IN_OPEN | IN_CLOSE) < 0) {
        close(p->opens);
        p->opens = -1;
    }
    if (p->opens < 0 && warn != NULL)
        fprintf(warn, "inotify unavailable (%s): a reconnecting client may see answers meant "
                      "for the previous one\n", strerror(errno));
    return 0;
}

static void track_clients(struct pk_serve_port *p)
{
    char evbuf[16 * (sizeof(struct inotify_event) + 16)]
        __attribute__((aligned(__alignof__(struct inotify_event))));
    ssize_t n;
    while ((n = read(p->opens, evbuf, sizeof evbuf)) > 0) {
        for (char *q = evbuf; q < evbuf + n;) {
            const struct inotify_event *e = (const struct inotify_event *)(void *)q;
            if (e->mask & IN_OPEN) {
                if (p->clients++ == 0)
                    p->connections++;
            }
            if ((e->mask & IN_CLOSE) && p->clients > 0 && --p->clients == 0) {
                /* the last client left: read what it sent before it closed,
                 * then have its unfinished line dropped */
                p->ser.rx_allow = (long)pk_serial_pending(&p->ser);
                p->draining = 1;
            }
            q += sizeof *e + e->len;
        }
    }
    if (p->clients > 0)
        p->alone_since_ns = 0;
    else if (p->alone_since_ns == 0)
        p->alone_since_ns = mono_ns();
    else if (mono_ns() - p->alone_since_ns >= 1000000000ull)
        pk_serial_discard_unread(&p->ser); /* nobody has been there for 1 s */
}

int pk_serve_port_pump(struct pk_serve_port *p, struct pk_uart *u)
{
    int flags = 0;
    if (p->opens >= 0)
        track_clients(p);
    if (p->draining && p->ser.rx_allow == 0 && pk_uart_rx_used(u) == 0) {
        p->ser.rx_allow = -1;
        p->draining = 0;
        flags |= PK_SERVE_PORT_LEFT;
    }
    uint64_t rx0 = p->ser.rx_bytes;
    int rc = pk_serial_pump(&p->ser, u);
    if (rc != 0)
        return rc;
    return flags | (p->ser.rx_bytes != rx0 ? PK_SERVE_PORT_RX : 0);
}

void pk_serve_port_signals(void (*on_stop)(int sig))
{
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_stop;
    sigemptyset(&sa.sa_mask);
    sigaction(SIGINT, &sa, NULL);
    sigaction(SIGTERM, &sa, NULL);
    signal(SIGPIPE, SIG_IGN);
}

void pk_serve_port_close(struct pk_serve_port *p)
{
    if (p->opens >= 0)
        close(p->opens);
    p->opens = -1;
    pk_serial_close(&p->ser);
}
