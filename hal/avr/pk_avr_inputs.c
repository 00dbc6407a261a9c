/*
 * pk_avr_inputs.c — the HAL's input lines on an AVR board (limit switches,
 * probe, door and buttons, as the board's board.h wires them; see "What an
 * input backend must do" in hal.h).
 *
 * input_read samples the pins (a few port reads, safe in the step interrupt).
 * input_watch turns on the board's edge sources — pin-change groups and
 * external interrupts set to "any change", whatever its pins have — and every
 * edge interrupt calls the core's callback with the levels read in the
 * interrupt and the step clock's tick. Those interrupts run with interrupts
 * off; the core's step callback runs with interrupts on for the serial line,
 * and an edge interrupt that comes meanwhile (in_step) only notes the edge
 * (in_pend): the step interrupt reports it once the step callback has
 * returned (pk_avr_input_pending, the levels read then), so the input
 * callback and the step callback never overlap, as hal.h requires. (The
 * step interrupt once masked the edge enables around every step callback
 * instead: about 30 cycles per callback, for edges that hardly ever come.)
 *
 * Built only for a board whose board.h defines PK_BOARD_INPUTS.
 */
#include "pk_avr.h"

#include <avr/interrupt.h>
#include <avr/io.h>
#include "board.h"

#ifdef PK_BOARD_INPUTS

int pk_avr_input_read(void *ctx, uint32_t *raw_levels)
{
    (void)ctx;
    *raw_levels = pk_board_input_read();
    return PK_HAL_OK;
}

int pk_avr_input_watch(void *ctx, pk_hal_input_cb cb, void *arg)
{
    struct pk_avr *a = ctx;
    uint8_t s = SREG;
    cli();
    a->in_cb = cb;
    a->in_arg = arg;
    pk_board_input_edges(cb != NULL);
    SREG = s;
    return PK_HAL_OK;
}

/* [ISR, interrupts off] One edge (or several at once) on the input lines. */
static void input_report(struct pk_avr *a)
{
    if (a->in_cb != NULL)
        a->in_cb(a->in_arg, pk_board_input_read(), pk_avr_clock_ticks(a));
}

void pk_avr_input_pending(struct pk_avr *a)
{
    a->in_pend = 0u;
    input_report(a);
}

static void input_edge(void)
{
    struct pk_avr *a = &pk_avr_board;
    if (a->in_step) {
        a->in_pend = 1u; /* inside the step callback: reported after it */
        return;
    }
    input_report(a);
}

ISR(PK_BOARD_INPUT_VECT0) { input_edge(); }
#ifdef PK_BOARD_INPUT_VECT1
ISR(PK_BOARD_INPUT_VECT1) { input_edge(); }
#endif
#ifdef PK_BOARD_INPUT_VECT2
ISR(PK_BOARD_INPUT_VECT2) { input_edge(); }
#endif
#ifdef PK_BOARD_INPUT_VECT3
ISR(PK_BOARD_INPUT_VECT3) { input_edge(); }
#endif

#endif /* PK_BOARD_INPUTS */
