/*
 * avr_refine_cycles.c — the subdivision kernel on an ATmega328P (16 MHz),
 * measured cycle-exactly under simavr by bench/avr_cycles.
 *
 * For Chaikin (B-spline degree 2) and the cubic B-spline at depths 1..6 it
 * smooths one open stroke of PK_AVR_POINTS input points the way firmware
 * would (push, pull until NEED_INPUT, finish, pull until END) and reports the
 * cycles of the whole stroke divided by the points it produced: cycles per
 * output point, amortising init, push and finish (plus closed Chaikin at
 * depth 4). Built like the board images, without the kernel's limit stage
 * (-DPK_BUILD_LIMIT=0). The consumer only stores
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
static volatile pk_um_t pk_avr_sink;
extern uint8_t __heap_start;                   /* avr-libc: first byte after .bss */

/* Input point i: a zig-zag spiral with every axis moving, |coordinate| <
 * 200 mm. Generated on the fly (a few cycles, inside the measurement): a
 * table would take RAM the kernel needs on a 2 KB part. */
static void pk_avr_point(uint8_t i, pk_um_t p[PK_AXES])
{
    int32_t r = 20000 + 6000 * (int32_t)i;
    p[0] = (i & 1) ? r : -r;
    p[1] = (i & 2) ? r >> 1 : -(r >> 2); /* r > 0: r / 2 and r / 4, without a library divide */
    if (PK_AXES > 2)
        p[PK_AXES - 1] = (int32_t)i * 125;
}

static uint32_t pk_avr_stroke(const struct pk_refine_cfg *cfg)
{
    struct pk_refine_out out;
    uint32_t n = 0;
    if (pk_refine_init(&pk_avr_stream, cfg) != PK_OK)
        return 0;
    for (uint8_t i = 0; i < PK_AVR_POINTS; i++) {
        pk_um_t p[PK_AXES];
        pk_avr_point(i, p);
        while (pk_refine_push(&pk_avr_stream, p) == PK_EBUSY)
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

/* The same stroke through the block pull, PK_AVR_BLOCK points per call into
 * a caller's buffer (what a consumer that takes points in batches does). */
#define PK_AVR_BLOCK 16
static pk_um_t pk_avr_buf[PK_AVR_BLOCK * PK_AXES];

static uint32_t pk_avr_drain_block(void)
{
    uint32_t n = 0, got;
    while (pk_refine_pull_block(&pk_avr_stream, pk_avr_buf, 0, PK_AVR_BLOCK, &got) == PK_OK && got > 0u)
        pk_avr_sink = pk_avr_buf[0], n += got;
    return n;
}

static uint32_t pk_avr_stroke_block(const struct pk_refine_cfg *cfg)
{
    uint32_t n = 0;
    if (pk_refine_init(&pk_avr_stream, cfg) != PK_OK)
        return 0;
    for (uint8_t i = 0; i < PK_AVR_POINTS; i++) {
        pk_um_t p[PK_AXES];
        pk_avr_point(i, p);
        while (pk_refine_push(&pk_avr_stream, p) == PK_EBUSY)
            n += pk_avr_drain_block();
        n += pk_avr_drain_block();
    }
    pk_refine_finish(&pk_avr_stream);
    return n + pk_avr_drain_block();
}

static void pk_avr_measure(const char *scheme, uint8_t degree, uint8_t depth, uint8_t limit, uint8_t closed)
{
    struct pk_refine_cfg cfg = { 0 };
    char label[28];
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
    cfg.closed = closed;
    avr_mark_begin(label);
    uint32_t n = scheme[0] == 'b' ? pk_avr_stroke_block(&cfg) : pk_avr_stroke(&cfg);
    avr_mark_end(n);
}

int main(void)
{
    /* Paint the free RAM between .bss and the stack; the untouched part at
     * the end tells how deep the stack went (reported as "= ..." rows). */
    for (uint8_t *q = &__heap_start; q < (uint8_t *)SP - 16; q++)
        *q = 0xA5;
    for (uint8_t d = 1; d <= 6; d++)
        pk_avr_measure("chaikin", 2, d, 0, 0);
    for (uint8_t d = 1; d <= 6; d++)
        pk_avr_measure("cubic", 3, d, 0, 0);
    for (uint8_t d = 3; d <= 5; d++)
        pk_avr_measure("block chaikin", 2, d, 0, 0);
    /* Closed strokes. (The limit stage is not measured here: the board
     * images are built without it (-DPK_BUILD_LIMIT=0), and its tables do not
     * fit the RAM of any AVR simavr models while avr-gcc copies them there.) */
    pk_avr_measure("chaikin closed", 2, 4, 0, 1);
    uint8_t *q = &__heap_start;
    while (q <= (uint8_t *)RAMEND && *q == 0xA5)
        q++;
    avr_mark_begin("= static RAM, bytes (.data+.bss)");
    avr_mark_end((uint32_t)(uint16_t)(&__heap_start - (uint8_t *)RAMSTART));
    avr_mark_begin("= peak stack, bytes");
    avr_mark_end((uint32_t)(uint16_t)((uint8_t *)RAMEND + 1 - q));
    avr_mark_begin("= RAM never touched, bytes");
    avr_mark_end((uint32_t)(uint16_t)(q - &__heap_start));
    cli();
    sleep_mode();
    return 0;
}
