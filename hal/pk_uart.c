/*
 * pk_uart.c — SPSC receive/transmit rings of the UART shim (see pk_uart.h).
 *
 * Free-running 8-bit indices: used = (uint8_t)(head - tail), which is exact
 * for ring sizes up to 128 because a ring never holds more than its size.
 * The producer writes the slot, then publishes head with release order; the
 * consumer loads head with acquire order before reading slots, and publishes
 * tail with release order after it has copied them out.
 */
#include "pk_uart.h"

#include <string.h>

#define RX_MASK ((uint8_t)(PK_UART_RX_SIZE - 1))
#define TX_MASK ((uint8_t)(PK_UART_TX_SIZE - 1))

void pk_uart_set_tx_kick(struct pk_uart *u, void (*fn)(void *ctx), void *ctx)
{
    u->tx_kick = fn;
    u->tx_kick_ctx = ctx;
}

void pk_uart_init(struct pk_uart *u, pk_uart_rt_filter filter, void *ctx)
{
    u->tx_kick = NULL;
    u->tx_kick_ctx = NULL;
    memset(u->rx, 0, sizeof u->rx);
    memset(u->tx, 0, sizeof u->tx);
    atomic_init(&u->rx_head, 0);
    atomic_init(&u->rx_tail, 0);
    atomic_init(&u->tx_head, 0);
    atomic_init(&u->tx_tail, 0);
    for (unsigned i = 0; i < 4u; i++)
        atomic_init(&u->rx_drop_b[i], 0);
    atomic_init(&u->rx_drop_seq, 0);
    atomic_init(&u->rx_overflows, 0);
    atomic_init(&u->rx_lost_at, 0);
    atomic_init(&u->rx_overflows_seen, 0);
    u->filter = filter;
    u->filter_ctx = ctx;
}

static uint8_t rx_used(const struct pk_uart *u)
{
    uint8_t h = atomic_load_explicit(&u->rx_head, memory_order_acquire);
    uint8_t t = atomic_load_explicit(&u->rx_tail, memory_order_acquire);
    return (uint8_t)(h - t);
}

/* Receive side only: add one to the 32-bit drop count under its seqlock. */
static void drop_count(struct pk_uart *u)
{
    uint8_t seq = atomic_load_explicit(&u->rx_drop_seq, memory_order_relaxed);
    atomic_store_explicit(&u->rx_drop_seq, (uint8_t)(seq + 1u), memory_order_relaxed);
    atomic_thread_fence(memory_order_release);
    uint8_t carry = 1u;
    for (unsigned i = 0; i < 4u && carry; i++) {
        uint8_t b = (uint8_t)(atomic_load_explicit(&u->rx_drop_b[i], memory_order_relaxed) + 1u);
        atomic_store_explicit(&u->rx_drop_b[i], b, memory_order_relaxed);
        carry = b == 0u;
    }
    atomic_store_explicit(&u->rx_drop_seq, (uint8_t)(seq + 2u), memory_order_release);
}

/* Receive side only: one byte lost at RX index h. One event per run of lost
 * bytes: a new event only once the main loop has seen the previous one (so
 * ev - seen is 0 or 1 and an 8-bit counter is exact). */
static void rx_loss(struct pk_uart *u, uint8_t h)
{
    drop_count(u);
    uint8_t ev = atomic_load_explicit(&u->rx_overflows, memory_order_relaxed);
    if (ev == atomic_load_explicit(&u->rx_overflows_seen, memory_order_acquire)) {
        atomic_store_explicit(&u->rx_lost_at, h, memory_order_relaxed);
        atomic_store_explicit(&u->rx_overflows, (uint8_t)(ev + 1u), memory_order_release);
    }
}

void pk_uart_rx_lost(struct pk_uart *u)
{
    rx_loss(u, atomic_load_explicit(&u->rx_head, memory_order_relaxed));
}

int pk_uart_rx_push(struct pk_uart *u, uint8_t byte)
{
    if (u->filter != NULL && u->filter(u->filter_ctx, byte))
        return PK_UART_RX_REALTIME;
    uint8_t h = atomic_load_explicit(&u->rx_head, memory_order_relaxed);
    uint8_t t = atomic_load_explicit(&u->rx_tail, memory_order_acquire);
    if ((uint8_t)(h - t) >= PK_UART_RX_SIZE) {
        rx_loss(u, h);
        return PK_UART_RX_DROPPED;
    }
    u->rx[h & RX_MASK] = byte;
    atomic_store_explicit(&u->rx_head, (uint8_t)(h + 1u), memory_order_release);
    return PK_UART_RX_STORED;
}

size_t pk_uart_rx_space(const struct pk_uart *u) { return PK_UART_RX_SIZE - rx_used(u); }

size_t pk_uart_rx_used(const struct pk_uart *u) { return rx_used(u); }

int pk_uart_read(struct pk_uart *u, uint8_t *buf, size_t len)
{
    uint8_t ev = atomic_load_explicit(&u->rx_overflows, memory_order_acquire);
    uint8_t t = atomic_load_explicit(&u->rx_tail, memory_order_relaxed);
    uint8_t h = atomic_load_explicit(&u->rx_head, memory_order_acquire);
    if (ev != atomic_load_explicit(&u->rx_overflows_seen, memory_order_relaxed)) {
        /* Deliver up to the point of loss, then report it there. */
        uint8_t at = atomic_load_explicit(&u->rx_lost_at, memory_order_relaxed);
        if (t == at) {
            atomic_store_explicit(&u->rx_overflows_seen, ev, memory_order_release);
            return PK_HAL_EIO;
        }
        h = at;
    }
    size_t n = 0;
    while (n < len && t != h) {
        buf[n++] = u->rx[t & RX_MASK];
        t++;
    }
    atomic_store_explicit(&u->rx_tail, t, memory_order_release);
    return (int)n;
}

int pk_uart_write(struct pk_uart *u, const uint8_t *buf, size_t len)
{
    uint8_t h = atomic_load_explicit(&u->tx_head, memory_order_relaxed);
    uint8_t t = atomic_load_explicit(&u->tx_tail, memory_order_acquire);
    size_t n = 0;
    while (n < len && (uint8_t)(h - t) < PK_UART_TX_SIZE) {
        u->tx[h & TX_MASK] = buf[n++];
        h++;
    }
    atomic_store_explicit(&u->tx_head, h, memory_order_release);
    if (n > 0 && u->tx_kick != NULL)
        u->tx_kick(u->tx_kick_ctx);
    return (int)n;
}

size_t pk_uart_tx_space(const struct pk_uart *u)
{
    uint8_t h = atomic_load_explicit(&u->tx_head, memory_order_relaxed);
    uint8_t t = atomic_load_explicit(&u->tx_tail, memory_order_acquire);
    return PK_UART_TX_SIZE - (uint8_t)(h - t);
}

size_t pk_uart_tx_pop(struct pk_uart *u, uint8_t *buf, size_t len)
{
    uint8_t t = atomic_load_explicit(&u->tx_tail, memory_order_relaxed);
    uint8_t h = atomic_load_explicit(&u->tx_head, memory_order_acquire);
    size_t n = 0;
    while (n < len && t != h) {
        buf[n++] = u->tx[t & TX_MASK];
        t++;
    }
    atomic_store_explicit(&u->tx_tail, t, memory_order_release);
    return n;
}

uint32_t pk_uart_rx_dropped(const struct pk_uart *u)
{
    for (;;) {
        uint8_t s0 = atomic_load_explicit(&u->rx_drop_seq, memory_order_acquire);
        uint32_t v = 0;
        for (unsigned i = 4u; i-- > 0u;)
            v = (v << 8) | atomic_load_explicit(&u->rx_drop_b[i], memory_order_relaxed);
        atomic_thread_fence(memory_order_acquire);
        uint8_t s1 = atomic_load_explicit(&u->rx_drop_seq, memory_order_relaxed);
        if (s0 == s1 && (s0 & 1u) == 0u)
            return v;
    }
}

int pk_uart_rx_overflow_pending(const struct pk_uart *u)
{
    return atomic_load_explicit(&u->rx_overflows, memory_order_acquire) !=
           atomic_load_explicit(&u->rx_overflows_seen, memory_order_relaxed);
}

int pk_uart_read_cb(void *ctx, uint8_t *buf, size_t len)
{
    return pk_uart_read((struct pk_uart *)ctx, buf, len);
}

int pk_uart_write_cb(void *ctx, const uint8_t *buf, size_t len)
{
    return pk_uart_write((struct pk_uart *)ctx, buf, len);
}

size_t pk_uart_rx_used_cb(void *ctx) { return pk_uart_rx_used((const struct pk_uart *)ctx); }
