/*
 * test_uart.c — the UART shim's rings (hal/pk_uart.c) and the pseudo-terminal
 * backend (hal/posix/pk_serial.c).
 */
#include <errno.h>
#include <fcntl.h>
#include <poll.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>
#include "th.h"
#include "pk_uart.h"
#include "posix/pk_serial.h"

int th_main(int argc, char **argv);

static void test_bytes_come_out_in_order_across_many_wraparounds(void)
{
    static struct pk_uart u;
    pk_uart_init(&u, NULL, NULL);
    uint8_t next_in = 0, next_out = 0;
    for (int round = 0; round < 1000; round++) {
        int k = 1 + round % 97;
        for (int i = 0; i < k; i++)
            TH_ASSERT_EQ(pk_uart_rx_push(&u, next_in++), PK_UART_RX_STORED);
        uint8_t buf[128];
        int n = pk_uart_read(&u, buf, sizeof buf);
        TH_ASSERT_EQ(n, k);
        for (int i = 0; i < n; i++)
            TH_ASSERT_EQ(buf[i], next_out++);
    }
    TH_EXPECT_EQ(pk_uart_rx_dropped(&u), 0);
}

static void test_the_rx_ring_holds_exactly_its_size_and_counts_every_lost_byte(void)
{
    static struct pk_uart u;
    pk_uart_init(&u, NULL, NULL);
    for (int i = 0; i < PK_UART_RX_SIZE; i++)
        TH_ASSERT_EQ(pk_uart_rx_push(&u, (uint8_t)i), PK_UART_RX_STORED);
    TH_EXPECT_EQ(pk_uart_rx_space(&u), 0);
    TH_EXPECT(!pk_uart_rx_overflow_pending(&u));
    for (int i = 0; i < 5; i++)
        TH_EXPECT_EQ(pk_uart_rx_push(&u, 0xAA), PK_UART_RX_DROPPED);
    TH_EXPECT_EQ(pk_uart_rx_dropped(&u), 5);
    TH_EXPECT(pk_uart_rx_overflow_pending(&u));
    uint8_t buf[256];
    /* The bytes received before the loss come out intact... */
    TH_ASSERT_EQ(pk_uart_read(&u, buf, 100), 100);
    for (int i = 0; i < 100; i++)
        TH_EXPECT_EQ(buf[i], i);
    /* ...bytes received after the loss wait behind its report... */
    TH_EXPECT_EQ(pk_uart_rx_push(&u, 0x55), PK_UART_RX_STORED);
    TH_ASSERT_EQ(pk_uart_read(&u, buf, sizeof buf), PK_UART_RX_SIZE - 100);
    for (int i = 100; i < PK_UART_RX_SIZE; i++)
        TH_EXPECT_EQ(buf[i - 100], i);
    /* ...the loss is reported once, exactly where it happened... */
    TH_EXPECT(pk_uart_rx_overflow_pending(&u));
    TH_EXPECT_EQ(pk_uart_read(&u, buf, sizeof buf), PK_HAL_EIO);
    TH_EXPECT(!pk_uart_rx_overflow_pending(&u));
    /* ...then what came after. */
    TH_EXPECT_EQ(pk_uart_read(&u, buf, sizeof buf), 1);
    TH_EXPECT_EQ(buf[0], 0x55);
    TH_EXPECT_EQ(pk_uart_read(&u, buf, sizeof buf), 0);
    /* A second overflow is a second event. */
    for (int i = 0; i <= PK_UART_RX_SIZE; i++)
        pk_uart_rx_push(&u, 1);
    TH_EXPECT_EQ(pk_uart_read(&u, buf, sizeof buf), PK_UART_RX_SIZE);
    TH_EXPECT_EQ(pk_uart_read(&u, buf, sizeof buf), PK_HAL_EIO);
    TH_EXPECT_EQ(pk_uart_rx_dropped(&u), 6);
}

/* The shared counters are bytes (no 32-bit atomics on AVR / Cortex-M0+):
 * the drop count must carry across its bytes exactly, and the 8-bit overflow
 * event counter must keep reporting every overflow after it wraps. */
static void test_the_drop_count_carries_across_bytes_and_events_survive_wrapping(void)
{
    static struct pk_uart u;
    pk_uart_init(&u, NULL, NULL);
    uint8_t buf[PK_UART_RX_SIZE];
    uint32_t lost = 0;
    for (int ev = 0; ev < 300; ev++) {
        while (pk_uart_rx_space(&u) > 0)
            TH_ASSERT_EQ(pk_uart_rx_push(&u, 7), PK_UART_RX_STORED);
        /* 70,000 bytes lost in the first event carries into the third byte. */
        uint32_t k = ev == 0 ? 70000u : 1u + (uint32_t)ev % 3u;
        for (uint32_t i = 0; i < k; i++)
            TH_ASSERT_EQ(pk_uart_rx_push(&u, 9), PK_UART_RX_DROPPED);
        lost += k;
        TH_ASSERT_EQ(pk_uart_rx_dropped(&u), lost);
        TH_ASSERT_EQ(pk_uart_read(&u, buf, sizeof buf), PK_UART_RX_SIZE);
        TH_ASSERT(pk_uart_rx_overflow_pending(&u));
        TH_ASSERT_EQ(pk_uart_read(&u, buf, sizeof buf), PK_HAL_EIO);
        TH_ASSERT(!pk_uart_rx_overflow_pending(&u));
        TH_ASSERT_EQ(pk_uart_read(&u, buf, sizeof buf), 0);
    }
    TH_EXPECT_EQ(lost, 70599u); /* 70000 + sum over ev = 1..299 of 1 + ev % 3 */
}

/* A byte the UART hardware lost (overrun, framing error) is reported exactly
 * like one the ring had no room for: where it went missing, once. */
static void test_a_byte_lost_by_the_hardware_is_reported_where_it_went_missing(void)
{
    static struct pk_uart u;
    pk_uart_init(&u, NULL, NULL);
    const char *a = "G1 X1\n", *b = "G1 X2\n";
    for (const char *p = a; *p; p++)
        TH_ASSERT_EQ(pk_uart_rx_push(&u, (uint8_t)*p), PK_UART_RX_STORED);
    pk_uart_rx_lost(&u);
    pk_uart_rx_lost(&u); /* a run of losses is one event */
    for (const char *p = b; *p; p++)
        TH_ASSERT_EQ(pk_uart_rx_push(&u, (uint8_t)*p), PK_UART_RX_STORED);
    TH_EXPECT_EQ(pk_uart_rx_dropped(&u), 2);
    uint8_t buf[32];
    TH_ASSERT_EQ(pk_uart_read(&u, buf, sizeof buf), (int)strlen(a));
    TH_EXPECT(memcmp(buf, a, strlen(a)) == 0);
    TH_EXPECT_EQ(pk_uart_read(&u, buf, sizeof buf), PK_HAL_EIO);
    TH_ASSERT_EQ(pk_uart_read(&u, buf, sizeof buf), (int)strlen(b));
    TH_EXPECT(memcmp(buf, b, strlen(b)) == 0);
    TH_EXPECT(!pk_uart_rx_overflow_pending(&u));
}

struct rt_log { uint8_t seen[16]; int n; };
static int rt_filter(void *ctx, uint8_t b)
{
    struct rt_log *l = ctx;
    if (b == '?' || b == '!' || b == '~' || b == 0x18) {
        if (l->n < 16)
            l->seen[l->n++] = b;
        return 1;
    }
    return 0;
}

static void test_realtime_bytes_are_claimed_and_never_stored_even_when_full(void)
{
    static struct pk_uart u;
    struct rt_log log = { { 0 }, 0 };
    pk_uart_init(&u, rt_filter, &log);
    const char *s = "G1?X!1~\x18";
    for (const char *p = s; *p; p++)
        pk_uart_rx_push(&u, (uint8_t)*p);
    uint8_t buf[16];
    TH_ASSERT_EQ(pk_uart_read(&u, buf, sizeof buf), 4);
    TH_EXPECT(memcmp(buf, "G1X1", 4) == 0);
    TH_ASSERT_EQ(log.n, 4);
    TH_EXPECT(memcmp(log.seen, "?!~\x18", 4) == 0);
    for (int i = 0; i < PK_UART_RX_SIZE; i++)
        pk_uart_rx_push(&u, 'A');
    TH_EXPECT_EQ(pk_uart_rx_push(&u, '!'), PK_UART_RX_REALTIME);
    TH_EXPECT_EQ(pk_uart_rx_dropped(&u), 0);
}

static void test_tx_accepts_only_what_fits_and_pops_in_order(void)
{
    static struct pk_uart u;
    pk_uart_init(&u, NULL, NULL);
    uint8_t src[300];
    for (int i = 0; i < 300; i++)
        src[i] = (uint8_t)(i * 7);
    TH_EXPECT_EQ(pk_uart_write(&u, src, sizeof src), PK_UART_TX_SIZE);
    TH_EXPECT_EQ(pk_uart_tx_space(&u), 0);
    uint8_t out[300];
    size_t n = pk_uart_tx_pop(&u, out, 10);
    TH_ASSERT_EQ(n, 10);
    TH_EXPECT_EQ(pk_uart_write(&u, src + PK_UART_TX_SIZE, 50), 10);
    n += pk_uart_tx_pop(&u, out + n, sizeof out - n);
    TH_ASSERT_EQ(n, PK_UART_TX_SIZE + 10);
    TH_EXPECT(memcmp(out, src, n) == 0);
}

/* Wait (bounded) until fd is readable. */
static int wait_readable(int fd, int ms)
{
    struct pollfd p = { fd, POLLIN, 0 };
    return poll(&p, 1, ms) == 1;
}

static unsigned kicks;
static size_t kicked_with; /* bytes in the ring when the kick came */
static struct pk_uart KU;
static void count_kick(void *ctx)
{
    TH_EXPECT(ctx == &KU);
    kicks++;
    kicked_with = PK_UART_TX_SIZE - pk_uart_tx_space(&KU);
}

/* The transmitter is started by the write itself, after the bytes are in
 * the ring (a board's main loop would otherwise start it only at the end
 * of its run: a status report held up by a long machine poll), and only
 * when bytes were added. */
static void test_a_write_starts_the_transmitter_once_its_bytes_are_in(void)
{
    pk_uart_init(&KU, NULL, NULL);
    const uint8_t msg[3] = { 'o', 'k', '\n' };
    TH_EXPECT_EQ(pk_uart_write(&KU, msg, 3), 3); /* no kick set: nothing called */
    TH_EXPECT_EQ(kicks, 0);
    pk_uart_set_tx_kick(&KU, count_kick, &KU);
    TH_EXPECT_EQ(pk_uart_write(&KU, msg, 3), 3);
    TH_EXPECT_EQ(kicks, 1);
    TH_EXPECT_EQ(kicked_with, 6);
    uint8_t fill[PK_UART_TX_SIZE];
    memset(fill, 'x', sizeof fill);
    int n = pk_uart_write(&KU, fill, sizeof fill);
    TH_EXPECT_EQ(n, PK_UART_TX_SIZE - 6);
    TH_EXPECT_EQ(kicks, 2);
    TH_EXPECT_EQ(pk_uart_write(&KU, msg, 1), 0); /* full: nothing added, no kick */
    TH_EXPECT_EQ(kicks, 2);
    pk_uart_init(&KU, NULL, NULL); /* init forgets it */
    TH_EXPECT_EQ(pk_uart_write(&KU, msg, 1), 1);
    TH_EXPECT_EQ(kicks, 2);
}

static void test_a_pty_client_and_the_shim_exchange_bytes_both_ways(void)
{
    static struct pk_uart u;
    struct rt_log log = { { 0 }, 0 };
    struct pk_serial s;
    pk_uart_init(&u, rt_filter, &log);
    char link[64];
    snprintf(link, sizeof link, "/tmp/pk_test_uart_%d", (int)getpid());
    TH_ASSERT_EQ(pk_serial_open_pty(&s, link), 0);
    TH_EXPECT(strncmp(s.path, "/dev/pts/", 9) == 0);
    int c = open(link, O_RDWR | O_NOCTTY);
    TH_ASSERT(c >= 0);
    /* The client writes 300 bytes: more than the ring; nothing may be lost. */
    uint8_t src[300];
    for (int i = 0; i < 300; i++)
        src[i] = (uint8_t)('A' + i % 26);
    src[150] = '?';
    TH_ASSERT_EQ(write(c, src, sizeof src), (ssize_t)sizeof src);
    uint8_t got[300];
    size_t n = 0;
    for (int spins = 0; spins < 2000 && n < 299; spins++) {
        wait_readable(s.fd, 5);
        TH_ASSERT_EQ(pk_serial_pump(&s, &u), 0);
        int r = pk_uart_read(&u, got + n, sizeof got - n);
        TH_ASSERT(r >= 0);
        n += (size_t)r;
    }
    TH_ASSERT_EQ(n, 299);
    TH_EXPECT(memcmp(got, src, 150) == 0 && memcmp(got + 150, src + 151, 149) == 0);
    TH_EXPECT_EQ(log.n, 1);
    TH_EXPECT_EQ(pk_uart_rx_dropped(&u), 0);
    /* And back: raw mode, so "\r\n" arrives unchanged. */
    const char *msg = "ok\r\nerror:20\r\n";
    TH_ASSERT_EQ(pk_uart_write(&u, (const uint8_t *)msg, strlen(msg)), (int)strlen(msg));
    TH_ASSERT_EQ(pk_serial_pump(&s, &u), 0);
    char back[64];
    size_t m = 0;
    while (m < strlen(msg) && wait_readable(c, 1000)) {
        ssize_t r = read(c, back + m, sizeof back - m);
        TH_ASSERT(r > 0);
        m += (size_t)r;
    }
    TH_ASSERT_EQ(m, strlen(msg));
    TH_EXPECT(memcmp(back, msg, m) == 0);
    /* The client leaves; the server side keeps working (no EIO busy loop). */
    close(c);
    TH_EXPECT_EQ(pk_serial_pump(&s, &u), 0);
    /* Answers written while nobody listens wait in the pty; they can be
     * discarded so that the next client does not read stale lines. */
    TH_EXPECT_EQ(pk_serial_unread(&s), 0);
    pk_uart_write(&u, (const uint8_t *)"ok\r\n", 4);
    TH_ASSERT_EQ(pk_serial_pump(&s, &u), 0);
    /* The tty layer hands the bytes to the slave side asynchronously. */
    for (int spins = 0; spins < 200 && pk_serial_unread(&s) < 4; spins++)
        wait_readable(s.slave_fd, 5);
    TH_EXPECT_EQ(pk_serial_unread(&s), 4);
    pk_serial_discard_unread(&s);
    TH_EXPECT_EQ(pk_serial_unread(&s), 0);
    pk_serial_close(&s);
    TH_EXPECT(access(link, F_OK) != 0);
}

static void test_opening_a_missing_device_or_bad_baud_fails_cleanly(void)
{
    struct pk_serial s;
    TH_EXPECT_EQ(pk_serial_open(&s, "/nonexistent/ttyUSB9", 115200), -ENOENT);
    TH_EXPECT_EQ(pk_serial_open(&s, "/dev/null", 12345), -EINVAL);
    TH_EXPECT(pk_serial_open(&s, "/dev/null", 115200) < 0); /* not a tty */
}

int th_main(int argc, char **argv)
{
    (void)argc;
    (void)argv;
    static const struct th_case cases[] = {
        TH_CASE(test_bytes_come_out_in_order_across_many_wraparounds),
        TH_CASE(test_the_rx_ring_holds_exactly_its_size_and_counts_every_lost_byte),
        TH_CASE(test_the_drop_count_carries_across_bytes_and_events_survive_wrapping),
        TH_CASE(test_a_byte_lost_by_the_hardware_is_reported_where_it_went_missing),
        TH_CASE(test_realtime_bytes_are_claimed_and_never_stored_even_when_full),
        TH_CASE(test_tx_accepts_only_what_fits_and_pops_in_order),
        TH_CASE(test_a_write_starts_the_transmitter_once_its_bytes_are_in),
        TH_CASE(test_a_pty_client_and_the_shim_exchange_bytes_both_ways),
        TH_CASE(test_opening_a_missing_device_or_bad_baud_fails_cleanly),
    };
    return th_run(cases, TH_COUNT(cases));
}
