/*
 * pk_avr_timer.c — the step timer of the AVR backend (see pk_avr.h).
 *
 * The board's 16-bit step timer runs freely at PK_BOARD_TICK_HZ; its overflow
 * interrupt counts wraps, so the clock is (overflows << 16 | TCNT), 48 bits
 * (four years at 2 MHz). A callback is scheduled on the compare unit:
 *
 *   service (the compare ISR; timer_start only arms the first event):
 *     loop:  now = clock
 *            next further than PK_AVR_TIMER_LEAD ticks ahead?
 *                write its low 16 bits to OCR, clear a stale match flag,
 *                read TCNT again: still before OCR -> done (the compare will
 *                fire); passed meanwhile -> go round (it is due now)
 *            else: wait until now >= next, next = cb(arg, now) with
 *                  interrupts on (this compare masked); 0 -> stop
 *
 * A next more than 65,536 ticks ahead matches at an earlier wrap of TCNT;
 * the ISR then finds it not yet due and arms it again. A callback is never
 * run before its tick, and a late one runs at once (the core's timing is
 * absolute, so lateness delays one edge and does not accumulate).
 */
#include "pk_avr.h"

#include <avr/interrupt.h>
#include <avr/io.h>
#include "board.h"

/* The clock is kept as two integers, the overflow count (bits 16..47) and the
 * counter (bits 0..15): avr-gcc handles 64-bit values through the stack and
 * libgcc helpers, which in the step interrupt cost more than the rest of this
 * file. Only the callback's argument and result are 64-bit. */
struct tick48 {
    uint32_t hi;
    uint16_t lo;
};

static inline __attribute__((always_inline)) struct tick48 now_irqoff(const struct pk_avr *a)
{
    struct tick48 t;
    t.lo = PK_BOARD_STEP_TCNT;
    t.hi = a->ovf;
    if ((PK_BOARD_STEP_TIFR & _BV(PK_BOARD_STEP_TOV)) && t.lo < 0x8000u)
        t.hi++;
    return t;
}

/* 48-bit tick <-> uint64_t byte by byte (AVR is little-endian): a 64-bit
 * shift would be a libgcc call. */
union pk_avr_u64 {
    uint64_t v;
    uint8_t b[8];
};

static inline __attribute__((always_inline)) uint64_t t64(struct tick48 t)
{
    union pk_avr_u64 u;
    u.b[0] = (uint8_t)t.lo;
    u.b[1] = (uint8_t)(t.lo >> 8);
    u.b[2] = (uint8_t)t.hi;
    u.b[3] = (uint8_t)(t.hi >> 8);
    u.b[4] = (uint8_t)(t.hi >> 16);
    u.b[5] = (uint8_t)(t.hi >> 24);
    u.b[6] = 0u;
    u.b[7] = 0u;
    return u.v;
}

/* Ticks from now until next, 0 if due or past, 0x10000 for "more than a
 * counter period away". */
static inline __attribute__((always_inline)) uint32_t ahead_of(uint32_t next_hi, uint16_t next_lo,
                                                               struct tick48 now)
{
    if (next_hi == now.hi)
        return next_lo > now.lo ? (uint16_t)(next_lo - now.lo) : 0u;
    if (next_hi == now.hi + 1u)
        return 0x10000u - now.lo + next_lo;
    return (int32_t)(next_hi - now.hi) > 0 ? 0x20000u : 0u;
}

/* Write the compare register for next (more than LEAD ticks ahead). Returns
 * 1 if the compare will fire for it, 0 if the counter passed it meanwhile.
 * (Interrupts off.) TIFR is never written here: a stale match flag costs at
 * most one spurious interrupt (service checks the time before any callback),
 * and simavr before 1.7 (Debian 12 ships 1.6) mishandles TIFR writes -- an
 * OCF write clears a pending TOV (simavr issue #414, fixed by #441) -- which
 * lost clock wraps, every later event 65,536 ticks late, under simavr. */
static inline __attribute__((always_inline)) uint8_t arm(const struct pk_avr *a, uint32_t d)
{
    uint16_t at = a->next_lo;
    PK_BOARD_STEP_OCR = at;
    /* at least 2 ticks left after the write: a compare written for the
     * counter's current or next value may not fire until the next wrap (on
     * simavr 1.6 at least, which then reschedules it a period later) */
    return d >= 0x8000u || (int16_t)(at - PK_BOARD_STEP_TCNT) > 1;
}

/* The compare interrupt (interrupts off on entry). The callback itself runs
 * with interrupts on and this compare masked, so the serial line, the clock
 * overflow and the servo are served while it works (the receiver holds only
 * two bytes: 170 us at 115200 baud) and the callback is never re-entered. */
static void service(struct pk_avr *a)
{
    PK_BOARD_STEP_TIMSK = (uint8_t)(PK_BOARD_STEP_TIMSK & (uint8_t)~_BV(PK_BOARD_STEP_OCIE));
    for (;;) {
        struct tick48 now = now_irqoff(a);
        uint32_t d = ahead_of(a->next_hi, a->next_lo, now);
        if (d > PK_AVR_TIMER_LEAD) {
            if (arm(a, d)) {
                PK_BOARD_STEP_TIMSK = (uint8_t)(PK_BOARD_STEP_TIMSK | _BV(PK_BOARD_STEP_OCIE));
                return;
            }
            continue;
        }
        while (d > 0u) {
            now = now_irqoff(a);
            d = ahead_of(a->next_hi, a->next_lo, now);
        }
        sei();
        uint64_t next = a->cb(a->cb_arg, t64(now));
        cli();
        union pk_avr_u64 nb = { .v = next };
        if ((nb.b[0] | nb.b[1] | nb.b[2] | nb.b[3] | nb.b[4] | nb.b[5] | nb.b[6] | nb.b[7]) == 0u) {
            a->armed = 0u;
            return;
        }
        a->next_lo = (uint16_t)(nb.b[0] | (uint16_t)nb.b[1] << 8);
        a->next_hi = nb.b[2] | (uint32_t)nb.b[3] << 8 | (uint32_t)nb.b[4] << 16 | (uint32_t)nb.b[5] << 24;
    }
}

ISR(PK_BOARD_STEP_COMP_vect)
{
    service(&pk_avr_board);
}

ISR(PK_BOARD_STEP_OVF_vect)
{
    pk_avr_board.ovf++;
}

void pk_avr_timer_init(struct pk_avr *a)
{
    a->cb = NULL;
    a->armed = 0u;
    a->ovf = 0u;
    PK_BOARD_STEP_TIMSK = 0u;
    PK_BOARD_STEP_TCCRA = 0u;
    PK_BOARD_STEP_TCCRB = 0u;
    PK_BOARD_STEP_TCNT = 0u;
    PK_BOARD_STEP_TIFR = (uint8_t)(_BV(PK_BOARD_STEP_OCF) | _BV(PK_BOARD_STEP_TOV));
    PK_BOARD_STEP_TIMSK = (uint8_t)_BV(PK_BOARD_STEP_TOIE);
    PK_BOARD_STEP_TCCRB = PK_BOARD_STEP_CS;
}

/* Only arms the compare: the first callback, like every other, runs from the
 * interrupt (at the earliest PK_AVR_TIMER_LEAD + 1 ticks from now, which the
 * core's absolute timing absorbs). */
int pk_avr_timer_start(void *ctx, pk_hal_timer_cb cb, void *arg, uint64_t first_tick)
{
    struct pk_avr *a = ctx;
    if (cb == NULL)
        return PK_HAL_EINVAL;
    uint8_t s = SREG;
    cli();
    a->cb = cb;
    a->cb_arg = arg;
    a->next_lo = (uint16_t)first_tick;
    a->next_hi = (uint32_t)(first_tick >> 16);
    a->armed = 1u;
    for (uint32_t margin = PK_AVR_TIMER_LEAD + 1u;; margin *= 2u) {
        struct tick48 now = now_irqoff(a);
        uint32_t d = ahead_of(a->next_hi, a->next_lo, now);
        if (d <= PK_AVR_TIMER_LEAD) {
            uint64_t t = t64(now) + margin;
            a->next_lo = (uint16_t)t;
            a->next_hi = (uint32_t)(t >> 16);
            d = margin;
        }
        if (arm(a, d))
            break;
    }
    PK_BOARD_STEP_TIMSK = (uint8_t)(PK_BOARD_STEP_TIMSK | _BV(PK_BOARD_STEP_OCIE));
    SREG = s;
    return PK_HAL_OK;
}

int pk_avr_timer_stop(void *ctx)
{
    struct pk_avr *a = ctx;
    uint8_t s = SREG;
    cli();
    PK_BOARD_STEP_TIMSK = (uint8_t)(PK_BOARD_STEP_TIMSK & (uint8_t)~_BV(PK_BOARD_STEP_OCIE));
    a->armed = 0u;
    SREG = s;
    return PK_HAL_OK;
}

uint64_t pk_avr_clock_ticks(void *ctx)
{
    uint8_t s = SREG;
    cli();
    struct tick48 t = now_irqoff(ctx);
    SREG = s;
    return t64(t);
}
