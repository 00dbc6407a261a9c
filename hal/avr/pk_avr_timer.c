/*
 * pk_avr_timer.c — the step timer and the step pulses of the AVR backend
 * (see pk_avr.h).
 *
 * The board's 16-bit step timer runs freely at PK_BOARD_TICK_HZ; its overflow
 * interrupt counts wraps, so the clock is (overflows << 16 | TCNT), 48 bits
 * (four years at 2 MHz); the callback sees its low 32 bits (hal.h). A
 * callback is scheduled on compare unit A:
 *
 *   service (the compare A ISR; timer_start only arms the first event):
 *     end a step pulse whose time is up (so no callback runs before it)
 *     now = clock
 *     next further than PK_AVR_TIMER_LEAD ticks ahead (a stale flag, or a
 *     next beyond the counter's range that matched at an earlier wrap)?
 *         write its low 16 bits to OCRA, read TCNT again: still before it
 *         -> done (the compare will fire); passed meanwhile -> it is due now
 *     wait until now >= next, delay = cb(arg, now) with interrupts on
 *     (a board with PK_AVR_STEP_INC: the step path compiled in here when cb
 *     is its PK_AVR_STEP_CB, no call);
 *     STOP -> stop; next = now + delay, OCRA = its low 16 bits (16-bit
 *     arithmetic: delay < 2^15 nearly always, no second clock read);
 *     more than LEAD ticks left on TCNT (or delay >= 2^15) -> done;
 *     else next = now + GAP, armed: one callback per interrupt, so that the
 *     main loop and the other interrupts get in first (the event is late by
 *     a few ticks, which the core's absolute timing absorbs)
 *
 * The bound matters: while the step events come faster than the callbacks
 * run, every event is due when the previous callback returns, and an
 * unbounded loop stays in the interrupt until the step ring is empty -- the
 * main loop, which refills it, starved (measured before the bound: one
 * compare interrupt of 191,588 cycles running 192 callbacks back to back at
 * 8,000 steps/s on the mega-ramps image, then an underrun; 42 of them). It
 * was two callbacks per interrupt until the step interrupt got cheaper: the
 * longest interrupt was then a line block's set-up and the step after it
 * (2,785 cycles on the bundled example, 1,815 with one callback); the mean
 * and the sustained step rate did not suffer (892 cycles per step instead of
 * 904 when it changed).
 *
 * A next more than 65,536 ticks ahead matches at an earlier wrap of TCNT;
 * the ISR then finds it not yet due and arms it again. A callback is never
 * run before its tick. The callback runs with interrupts on, so that the
 * serial line, the clock overflow, the servo and the pulse end are served
 * meanwhile; compare A is masked then whenever its flag may be set again
 * inside the callback, which would enter this interrupt a second time and
 * run the callback inside itself (two of them consuming the step ring at
 * once lost steps: 189 of 8,540 at 17,000 steps/s on mega-ramps while the
 * ISR masked only after an arm that found its tick passed): after such an
 * arm, when the event was waited for inside the interrupt or is less than
 * two ticks old (its match may still come), or when the flag is set. Else
 * OCRA holds a tick whose match has come and gone (its flag clear), which
 * the counter reaches again only 65,536 ticks later.
 *
 * Step pulses (pk_avr_step_pulse, the HAL's step_pulse): the lines go active
 * at once and compare unit B's interrupt returns them to idle width ticks
 * later (Grbl ends its pulses with a second interrupt likewise), so a step
 * costs one callback. Neither compare's flag is ever cleared by a TIFR write
 * (simavr before 1.7, which Debian 12 ships, mishandles them: an OCF write
 * clears a pending TOV, simavr issue #414, fixed by #441, which lost clock
 * wraps); a stale flag costs one interrupt that finds its time not yet come.
 */
#include "pk_avr.h"

#include <avr/interrupt.h>
#include <avr/io.h>
#include "board.h"
#include "pk_avr_pulse.h"
#ifdef PK_AVR_STEP_INC
/* the board compiles the step path into this interrupt (board.mk:
 * PK_AVR_STEP_INC, pk_avr_step.h, which names the callback PK_AVR_STEP_CB,
 * its argument PK_AVR_STEP_ARG and PK_AVR_STEP_FN, the same code inline):
 * for that callback and argument, the vector calls nothing on a step event
 * and saves the registers the step path uses once, not once per call frame
 * (the vector's, the callback's, pk_sg_isr's); any other callback is called
 * as usual */
#include PK_AVR_STEP_INC
#endif

/** An event due when the interrupt's callback returns is armed this many
 *  ticks ahead (more than the few ticks between reading the clock and writing OCRA, or
 *  the write would find the tick passed every time). */
#define PK_AVR_TIMER_GAP 16u

/* The clock's low 32 bits: overflow count (low half) and counter. A pending
 * overflow not yet counted (the counter wrapped since the overflow ISR ran)
 * adds one. Interrupts off. */
static inline __attribute__((always_inline)) uint32_t now32(const struct pk_avr *a)
{
    uint16_t lo = PK_BOARD_STEP_TCNT;
    uint16_t hi = a->ovf_lo;
    if ((PK_BOARD_STEP_TIFR & _BV(PK_BOARD_STEP_TOV)) && lo < 0x8000u)
        hi++;
    /* hi:lo as two register moves (avr-gcc assembles (uint32_t)hi << 16 | lo
     * through a dozen, twice per step interrupt); multi-byte values sit in
     * even register pairs, as movw needs */
    uint32_t v;
    __asm__("movw %A0, %A1\n\tmovw %C0, %A2" : "=&r"(v) : "r"(lo), "r"(hi));
    return v;
}

/* Write the compare register for next (d = next - now > LEAD ticks ahead).
 * Returns 1 if the compare will fire for it, 0 if the counter passed it
 * meanwhile. (Interrupts off.) At least 4 ticks must be left after the
 * write: a compare written for a value the counter reaches within a tick or
 * two may not fire until the next wrap, 32.8 ms later (simavr 1.6 at least;
 * with 2 ticks, the margin this once had, timer_start's first arm after an
 * underrun missed now and then once the clock read got a few cycles faster:
 * the strokes drawing on mega-ramps took 10.13 s on the chip instead of
 * 9.73 s). A refused arm costs a retry with a wider margin (timer_start) or
 * a wait of a few ticks inside the interrupt (service). */
static inline __attribute__((always_inline)) uint8_t arm(const struct pk_avr *a, uint32_t d)
{
    uint16_t at = (uint16_t)a->next;
    PK_BOARD_STEP_OCR = at;
    return d >= 0x8000u || (int16_t)(at - PK_BOARD_STEP_TCNT) > 3;
}

/* (ira-algorithm=priority: avr-gcc 5.4's other register allocator, for
 * this one large function: one register fewer to save and fewer moves,
 * 616 cycles a step instead of 623 (when chosen) on the 17,000 steps/s X
 * move on mega-ramps; the same C, only its registers differ. Tried and
 * dropped:
 * the rare calls through an assembly sequence saving the call-clobbered
 * registers itself, so that the vector calls nothing: the allocator then
 * used as many registers as before, and the vector cost 626 cycles a
 * step, not 608) */
ISR(PK_BOARD_STEP_COMP_vect, __attribute__((optimize("ira-algorithm=priority"))))
{
    struct pk_avr *a = &pk_avr_board;
    if (pk_avr_pulse_armed() && pk_avr_pulse_due(a))
        pk_avr_pulse_end(a);
    uint32_t now = now32(a);
    int32_t d = (int32_t)(a->next - now);
    uint8_t hold_cmp = 0u;
    if (d > (int32_t)PK_AVR_TIMER_LEAD) {
        if (arm(a, (uint32_t)d))
            return;
        hold_cmp = 1u; /* passed while armed: due now, its flag may be set */
    }
    while (d > 0) {
        now = now32(a);
        d = (int32_t)(a->next - now);
    }
    /* OCRA holds next's low bits: its match may come after this interrupt
     * was entered (entered on a stale flag, or waited for above) and set the
     * flag again, which would enter this interrupt inside the callback. Two
     * ticks past next, any match has set it already (a flag is set a timer
     * clock after the match): then the flag says it; closer, assume it. */
    if (d > -2 || (PK_BOARD_STEP_TIFR & _BV(PK_BOARD_STEP_OCF)))
        hold_cmp = 1u;
    if (hold_cmp)
        PK_BOARD_STEP_TIMSK = (uint8_t)(PK_BOARD_STEP_TIMSK & (uint8_t)~_BV(PK_BOARD_STEP_OCIE));
#ifdef PK_BOARD_INPUTS
    a->in_step = 1u; /* an input edge meanwhile waits (pk_avr_inputs.c) */
#endif
    sei();
#ifdef PK_AVR_STEP_FN
    uint32_t delay = a->cb_inline ? PK_AVR_STEP_FN(now) : a->cb(a->cb_arg, now);
#else
    uint32_t delay = a->cb(a->cb_arg, now);
#endif
    cli();
#ifdef PK_BOARD_INPUTS
    a->in_step = 0u;
#endif
    if (delay == PK_HAL_TIMER_STOP) {
        PK_BOARD_STEP_TIMSK = (uint8_t)(PK_BOARD_STEP_TIMSK & (uint8_t)~_BV(PK_BOARD_STEP_OCIE));
        a->armed = 0u;
    } else {
        if (hold_cmp)
            PK_BOARD_STEP_TIMSK = (uint8_t)(PK_BOARD_STEP_TIMSK | _BV(PK_BOARD_STEP_OCIE));
        uint32_t next = now + delay;
        a->next = next;
        /* |next - now| < 2^15 (nearly every step): the counter difference
         * is the event's distance; more than LEAD ticks left after the
         * write: the compare fires, as arm() decides */
        uint16_t at = (uint16_t)next;
        PK_BOARD_STEP_OCR = at;
        if (delay < 0x8000u && (int16_t)(at - PK_BOARD_STEP_TCNT) <= (int16_t)PK_AVR_TIMER_LEAD) {
            /* due within LEAD ticks, or passed: the next interrupt, GAP
             * ticks on (more than LEAD: the compare fires) */
            next = now32(a) + PK_AVR_TIMER_GAP;
            a->next = next;
            PK_BOARD_STEP_OCR = (uint16_t)next;
        }
    }
#ifdef PK_BOARD_INPUTS
    if (a->in_pend)
        pk_avr_input_pending(a); /* the edge that came during the callback */
#endif
}

/* Compare B: the end of a step pulse (or a stale match: not yet its time),
 * once per step: pk_avr_pulse_due and pk_avr_pulse_end (pk_avr_pulse.h) in
 * assembly, saving only the three registers and SREG it uses (the compiled
 * handler saved nine and rebuilt the port bits from the axis masks: 99
 * cycles a pulse on mega-ramps; this, 62). r1 is not assumed zero (the
 * interrupted code may be between a mul and its clearing). TCNT's low byte
 * is read first (it latches the high byte), as the compiler does. */
ISR(PK_BOARD_PULSE_COMP_vect, ISR_NAKED)
{
    __asm__ volatile(
        "push r24\n\t"
        "in r24, __SREG__\n\t"
        "push r24\n\t"
        "push r25\n\t"
        "push r26\n\t"
        /* (int16_t)(TCNT - pulse_end) < 0: not yet */
        "lds r24, %[tcnt]\n\t"
        "lds r25, %[tcnt]+1\n\t"
        "lds r26, %[end]\n\t"
        "cp r24, r26\n\t"
        "lds r26, %[end]+1\n\t"
        "cpc r25, r26\n\t"
        "brmi 3f\n\t"
        /* port 0 = (port 0 | m0) ^ v0 (m0 0: not written) */
        "lds r25, %[m0]\n\t"
        "tst r25\n\t"
        "breq 1f\n\t"
        "in r24, %[p0]\n\t"
        "or r24, r25\n\t"
        "lds r25, %[v0]\n\t"
        "eor r24, r25\n\t"
        "out %[p0], r24\n"
        "1:\n\t"
#ifdef PK_BOARD_STEP_PORT1
        "lds r25, %[m1]\n\t"
        "tst r25\n\t"
        "breq 2f\n\t"
        "lds r24, %[p1]\n\t"
        "or r24, r25\n\t"
        "lds r25, %[v1]\n\t"
        "eor r24, r25\n\t"
        "sts %[p1], r24\n"
        "2:\n\t"
#endif
        /* compare B's interrupt off */
        "lds r24, %[timsk]\n\t"
        "andi r24, %[noie]\n\t"
        "sts %[timsk], r24\n"
        "3:\n\t"
        "pop r26\n\t"
        "pop r25\n\t"
        "pop r24\n\t"
        "out __SREG__, r24\n\t"
        "pop r24\n\t"
        "reti"
        :
        : [tcnt] "n"(_SFR_MEM_ADDR(PK_BOARD_STEP_TCNT)), [end] "i"(&pk_avr_board.pulse_end),
          [m0] "i"(&pk_avr_board.pulse_m0), [v0] "i"(&pk_avr_board.pulse_v0),
          [p0] "I"(_SFR_IO_ADDR(PK_BOARD_STEP_PORT0)),
#ifdef PK_BOARD_STEP_PORT1
          [m1] "i"(&pk_avr_board.pulse_m1), [v1] "i"(&pk_avr_board.pulse_v1),
          [p1] "n"(_SFR_MEM_ADDR(PK_BOARD_STEP_PORT1)),
#endif
          [timsk] "n"(_SFR_MEM_ADDR(PK_BOARD_STEP_TIMSK)),
          [noie] "n"((uint8_t)~_BV(PK_BOARD_PULSE_OCIE)));
}

ISR(PK_BOARD_STEP_OVF_vect)
{
    struct pk_avr *a = &pk_avr_board;
    if (++a->ovf_lo == 0u)
        a->ovf_hi++;
}

int pk_avr_step_pulse8(void *ctx, uint8_t mask, uint8_t levels, uint16_t width_ticks)
{
    return pk_avr_step_pulse8_inline(ctx, mask, levels, width_ticks);
}

int pk_avr_step_pulse(void *ctx, uint32_t mask, uint32_t levels, uint32_t width_ticks)
{
    return pk_avr_step_pulse8(ctx, (uint8_t)mask, (uint8_t)levels,
                              width_ticks > 0xFFFFu ? 0xFFFFu : (uint16_t)width_ticks);
}

void pk_avr_timer_init(struct pk_avr *a)
{
    a->cb = NULL;
#ifdef PK_AVR_STEP_FN
    a->cb_inline = 0u;
#endif
    a->armed = 0u;
    a->ovf_lo = 0u;
    a->ovf_hi = 0u;
    a->in_step = 0u;
    a->in_pend = 0u;
    PK_BOARD_STEP_TIMSK = 0u;
    PK_BOARD_STEP_TCCRA = 0u;
    PK_BOARD_STEP_TCCRB = 0u;
    PK_BOARD_STEP_TCNT = 0u;
    PK_BOARD_STEP_TIFR = (uint8_t)(_BV(PK_BOARD_STEP_OCF) | _BV(PK_BOARD_PULSE_OCF) | _BV(PK_BOARD_STEP_TOV));
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
#ifdef PK_AVR_STEP_FN
    /* the step path inline only for exactly the callback, argument and HAL
     * it is compiled for (pk_avr_step.h); decided here, not per event */
    a->cb_inline = cb == PK_AVR_STEP_CB && arg == (void *)PK_AVR_STEP_ARG && PK_AVR_STEP_ARG->hal == PK_AVR_STEP_HAL;
#endif
    a->armed = 1u;
    uint64_t now64 = pk_avr_clock_ticks(ctx);
    /* first_tick in the past, or further than 2^31 ticks: at once / capped */
    uint64_t ahead = first_tick > now64 ? first_tick - now64 : 0u;
    a->next = (uint32_t)now64 + (uint32_t)(ahead > 0x7FFFFFFFu ? 0x7FFFFFFFu : ahead);
    for (uint32_t margin = PK_AVR_TIMER_LEAD + 1u;; margin *= 2u) {
        uint32_t now = now32(a);
        int32_t d = (int32_t)(a->next - now);
        if (d <= (int32_t)PK_AVR_TIMER_LEAD) {
            a->next = now + margin;
            d = (int32_t)margin;
        }
        if (arm(a, (uint32_t)d))
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

/* 48-bit clock, assembled byte by byte (AVR is little-endian): a 64-bit
 * shift would be a libgcc call. MAIN (also called by timer_start). */
uint64_t pk_avr_clock_ticks(void *ctx)
{
    const struct pk_avr *a = ctx;
    uint8_t s = SREG;
    cli();
    uint16_t lo = PK_BOARD_STEP_TCNT;
    uint16_t mid = a->ovf_lo;
    uint16_t hi = a->ovf_hi;
    if ((PK_BOARD_STEP_TIFR & _BV(PK_BOARD_STEP_TOV)) && lo < 0x8000u && ++mid == 0u)
        hi++;
    SREG = s;
    union {
        uint64_t v;
        uint8_t b[8];
    } u;
    u.b[0] = (uint8_t)lo;
    u.b[1] = (uint8_t)(lo >> 8);
    u.b[2] = (uint8_t)mid;
    u.b[3] = (uint8_t)(mid >> 8);
    u.b[4] = (uint8_t)hi;
    u.b[5] = (uint8_t)(hi >> 8);
    u.b[6] = 0u;
    u.b[7] = 0u;
    return u.v;
}
