/*
 * avr_refine_cycles.c — the subdivision kernel on an ATmega328P (16 MHz),
 * measured cycle-exactly under simavr by bench/avr_cycles.
 *
 * For Chaikin (B-spline degree 2) and the cubic B-spline at depths 1..6 it
 * smooths one open stroke of PK_AVR_POINTS input points the way firmware
 * would (push, pull until NEED_INPUT, finish, pull until END) and reports the
 * cycles of the whole stroke divided by the points it produced: cycles per
 * output point, amortising init, push and finish. The consumer only stores
 * the point in a volatile sink (a few cycles). Built once per PK_AXES value.
 */
#include <stdint.h>
#include <avr/interrupt.h>
#include <avr/sleep.h>
#include "avr_mcu_section.h"
#include "avr_mark.h"
#include "pk_refine.h"

AVR_MCU(F_CPU, "atmega328p");

#define PK_AVR_POINTS 24

static struct pk_refine pk_avr_stream;         /* 1 stream: statics keep the stack small */
static pk_um_t pk_avr_in[PK_AVR_POINTS][PK_AXES];
static volatile pk_um_t pk_avr_sink;

static uint32_t pk_avr_stroke(const struct pk_refine_cfg *cfg)
{
    struct pk_refine_out out;
    uint32_t n = 0;
    if (pk_refine_init(&pk_avr_stream, cfg) != PK_OK)
        return 0;
    for (uint8_t i = 0; i < PK_AVR_POINTS; i++) {
        while (pk_refine_push(&pk_avr_stream, pk_avr_in[i]) == PK_EBUSY)
            while (pk_refine_pull(&pk_avr_stream, &out) == PK_OK)
                pk_avr_sink = out.p[0], n++;
        while (pk_refine_pull(&pk_avr_stream, &out) == PK_OK)
            pk_avr_sink = out.p[0], n++;
    }
    pk_refine_finish(&pk_avr_stream);
    while (pk_refine_pull(&pk_avr_stream, &out) == PK_OK)
        pk_avr_sink = out.p[0], n++;
    return n;
}

static void pk_avr_measure(const char *scheme, uint8_t degree, uint8_t depth, uint8_t limit)
{
    struct pk_refine_cfg cfg = { 0 };
    char label[24];
    uint8_t k = 0;
    for (const char *s = scheme; *s; s++)
        label[k++] = *s;
    label[k++] = ' ';
    label[k++] = 'd';
    label[k++] = (char)('0' + depth);
    label[k] = '\0';
    cfg.scheme = PK_SCHEME_BSPLINE;
    cfg.degree = degree;
    cfg.depth = depth;
    cfg.limit = limit;
    avr_mark_begin(label);
    uint32_t n = pk_avr_stroke(&cfg);
    avr_mark_end(n);
}

int main(void)
{
    /* A zig-zag spiral with every axis moving, |coordinate| < 200 mm. */
    for (uint8_t i = 0; i < PK_AVR_POINTS; i++) {
        int32_t r = 20000 + 6000 * (int32_t)i;
        pk_avr_in[i][0] = (i & 1) ? r : -r;
        pk_avr_in[i][1] = (i & 2) ? r / 2 : -r / 3;
        if (PK_AXES > 2)
            pk_avr_in[i][PK_AXES - 1] = (int32_t)i * 125;
    }
    for (uint8_t d = 1; d <= 6; d++)
        pk_avr_measure("chaikin", 2, d, 0);
    for (uint8_t d = 1; d <= 6; d++)
        pk_avr_measure("cubic", 3, d, 0);
    pk_avr_measure("chaikin+limit", 2, 4, 1);
    cli();
    sleep_mode();
    return 0;
}
