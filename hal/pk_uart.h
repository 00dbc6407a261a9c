/*
 * pk_uart.h — plotkin's UART byte-stream shim: receive and transmit rings
 * sized at compile time between an interrupt (or a simulator pump) and the
 * main loop.
 *
 * Each ring is single-producer single-consumer and each index has exactly one
 * writer: the RX head is written only by the receive side (the RX interrupt,
 * or pk_serial_pump on a host), the RX tail only by the main loop
 * (pk_uart_read); the TX head only by the main loop (pk_uart_write), the TX
 * tail only by the transmit side (pk_uart_tx_pop). Indices are free-running
 * 8-bit counters published with C11 release/acquire atomics, so all
 * PK_UART_*_SIZE slots are usable and a byte is visible before its index.
 *
 * Every object shared between the two sides is one byte wide, so every
 * access is a single load or store on any target (an 8-bit AVR included)
 * and no target needs the __atomic_*_4 library helpers that a 32-bit atomic
 * becomes on AVR and Cortex-M0+ (which neither libgcc, newlib nor avr-libc
 * provide). The cumulative drop counter is 32 bits made of four atomic
 * bytes under an 8-bit sequence counter (a seqlock): the receive side makes
 * the sequence odd, writes the bytes, makes it even again; a reader retries
 * until it sees the same even sequence before and after its read. On a
 * board the receive side is an interrupt that the main loop cannot
 * interrupt, so the reader never retries more than once per interrupt; on a
 * host the same protocol is correct between two threads.
 *
 * Realtime bytes: a filter installed at init sees every received byte first,
 * in the receive context; when it claims a byte (Grbl's '?', '!', '~', 0x18)
 * the byte is acted on there and never enters the ring, so it can neither be
 * delayed behind a full line buffer nor corrupt the line it arrived in.
 *
 * Overflow is never silent: a byte that finds the RX ring full is counted
 * (rx_dropped, cumulative) and latches the overflow flag together with the
 * position in the stream where bytes went missing. pk_uart_read delivers the
 * intact bytes received before that point, then returns PK_HAL_EIO once
 * exactly there (the caller discards the line in progress), then the bytes
 * received afterwards. Further losses before the first one is reported are
 * merged into it (counted, but flagged at the first position only).
 *
 * Memory: one struct pk_uart per port, owned by the caller; no heap, no
 * globals. The same code runs on a board (ISR producer) and on the host.
 */
#ifndef PLOTKIN_PK_UART_H
#define PLOTKIN_PK_UART_H

#include <stdatomic.h>
#include <stddef.h>
#include <stdint.h>
#include "hal.h"

/** Receive ring size: a power of two, 2..128. Grbl senders count against 128. */
#ifndef PK_UART_RX_SIZE
#define PK_UART_RX_SIZE 128
#endif
/** Transmit ring size: a power of two, 2..128. */
#ifndef PK_UART_TX_SIZE
#define PK_UART_TX_SIZE 128
#endif
#if PK_UART_RX_SIZE < 2 || PK_UART_RX_SIZE > 128 || (PK_UART_RX_SIZE & (PK_UART_RX_SIZE - 1))
#error "PK_UART_RX_SIZE must be a power of two in 2..128"
#endif
#if PK_UART_TX_SIZE < 2 || PK_UART_TX_SIZE > 128 || (PK_UART_TX_SIZE & (PK_UART_TX_SIZE - 1))
#error "PK_UART_TX_SIZE must be a power of two in 2..128"
#endif

/**
 * Realtime filter, called in the receive context for every byte before it is
 * stored. Return non-zero to claim the byte (it is then not stored).
 * Must be short, non-blocking, and safe against the main loop (ISR rules).
 */
typedef int (*pk_uart_rt_filter)(void *ctx, uint8_t byte);

/** One port's rings. Private members: use the functions. */
struct pk_uart {
    uint8_t rx[PK_UART_RX_SIZE];
    uint8_t tx[PK_UART_TX_SIZE];
    _Atomic uint8_t rx_head;      /**< written by the receive side only */
    _Atomic uint8_t rx_tail;      /**< written by the main loop only */
    _Atomic uint8_t tx_head;      /**< written by the main loop only */
    _Atomic uint8_t tx_tail;      /**< written by the transmit side only */
    _Atomic uint8_t rx_drop_b[4]; /**< bytes lost to a full ring, little-endian
                                       (receive side; read with pk_uart_rx_dropped) */
    _Atomic uint8_t rx_drop_seq;  /**< seqlock of rx_drop_b: odd while it is written */
    _Atomic uint8_t rx_overflows; /**< overflow events mod 256 (receive side); it runs
                                       at most one ahead of rx_overflows_seen */
    _Atomic uint8_t rx_lost_at;   /**< RX index where the first unreported loss happened */
    _Atomic uint8_t rx_overflows_seen; /**< main loop's copy: flag = overflows != seen
                                       (written by the main loop only) */
    pk_uart_rt_filter filter;
    void *filter_ctx;
    void (*tx_kick)(void *ctx);   /**< pk_uart_set_tx_kick */
    void *tx_kick_ctx;
};

/** Result of pk_uart_rx_push. */
enum pk_uart_rx_result {
    PK_UART_RX_STORED = 0,   /**< the byte is in the ring */
    PK_UART_RX_REALTIME = 1, /**< the filter claimed it */
    PK_UART_RX_DROPPED = 2   /**< the ring was full: counted, flag latched */
};

/**
 * Initialise (empty rings, counters zero).
 * @param filter  realtime filter, or NULL
 * @param ctx     passed to the filter
 * Calling context: MAIN, before the receive side is enabled.
 */
void pk_uart_init(struct pk_uart *u, pk_uart_rt_filter filter, void *ctx);

/**
 * Start the transmit side as soon as bytes are written: pk_uart_write calls
 * fn(ctx) after it has added any (in the writer's context), e.g. to enable
 * the transmit interrupt. Without it the board starts the transmitter once
 * per main loop run, and an answer written early in a long run (a status
 * report the machine's poll then holds up for hundreds of milliseconds on
 * an 8-bit core) waits for the end of it.
 * @param fn  NULL: none (the default)
 * Calling context: MAIN.
 */
void pk_uart_set_tx_kick(struct pk_uart *u, void (*fn)(void *ctx), void *ctx);

/** [ISR / receive side] Offer one received byte. See enum pk_uart_rx_result. */
int pk_uart_rx_push(struct pk_uart *u, uint8_t byte);

/**
 * [ISR / receive side] Report one byte lost before it reached the ring (a
 * UART data overrun or framing error): counted and flagged exactly like a
 * byte that found the ring full, at the current position of the stream.
 */
void pk_uart_rx_lost(struct pk_uart *u);

/** [receive side] Free RX slots right now (a pump reads at most this many). */
size_t pk_uart_rx_space(const struct pk_uart *u);

/** [MAIN] Bytes waiting in the RX ring. */
size_t pk_uart_rx_used(const struct pk_uart *u);

/**
 * [MAIN] Take up to len received bytes.
 * @return bytes copied (0 if none), or PK_HAL_EIO once at the point of an
 *         overflow (no bytes copied; call again for the data that follows)
 */
int pk_uart_read(struct pk_uart *u, uint8_t *buf, size_t len);

/** [MAIN] Queue up to len bytes for transmission; returns bytes accepted. */
int pk_uart_write(struct pk_uart *u, const uint8_t *buf, size_t len);

/** [MAIN] Free TX slots. */
size_t pk_uart_tx_space(const struct pk_uart *u);

/** [ISR / transmit side] Take up to len bytes to send; returns the count. */
size_t pk_uart_tx_pop(struct pk_uart *u, uint8_t *buf, size_t len);

/** [any] Cumulative bytes lost to RX overflow. */
uint32_t pk_uart_rx_dropped(const struct pk_uart *u);

/** [MAIN] Non-zero while an overflow has not yet been reported by pk_uart_read. */
int pk_uart_rx_overflow_pending(const struct pk_uart *u);

/* Adapters with the pk_hal_ops uart_read/uart_write signature (ctx = the
 * struct pk_uart), for a HAL backend or a protocol stream. */
int pk_uart_read_cb(void *ctx, uint8_t *buf, size_t len);
int pk_uart_write_cb(void *ctx, const uint8_t *buf, size_t len);
size_t pk_uart_rx_used_cb(void *ctx);

#endif
