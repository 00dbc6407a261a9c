/*
 * avr_mark.h — cycle markers for AVR programs measured by bench/avr_cycles
 * (libsimavr). The host hooks writes to three general-purpose I/O registers,
 * which cost one `out` instruction each and touch no peripheral:
 *
 *   GPIOR1 <- c     append a character to the label of the next measurement
 *   GPIOR0 <- 1     start: the host stamps the cycle counter
 *   GPIOR0 <- 2     stop:  the host adds the cycles since start to the
 *                   measurement (several start/stop pairs accumulate; the
 *                   longest pair is kept too)
 *   GPIOR2 <- b     shift a byte into the item count (big-endian, 4 bytes)
 *   GPIOR0 <- 3     report: the host prints label, cycles, items, cycles/item
 *                   (labels starting with "= " print the items as a value)
 *
 * Only the instructions between start and stop are counted (plus the one
 * `out` of the stop itself). A new measurement needs no change on the host
 * side: avr_mark_begin("name") ... avr_mark_end(items), or avr_mark_label +
 * many avr_mark_start/avr_mark_stop pairs + avr_mark_report(items).
 */
#ifndef PLOTKIN_AVR_MARK_H
#define PLOTKIN_AVR_MARK_H

#include <stdint.h>
#include <avr/io.h>

static inline void avr_mark_label(const char *label)
{
    while (*label)
        GPIOR1 = (uint8_t)*label++;
}

static inline void avr_mark_start(void)
{
    __asm__ volatile("" ::: "memory");
    GPIOR0 = 1;
    __asm__ volatile("" ::: "memory");
}

static inline void avr_mark_stop(void)
{
    __asm__ volatile("" ::: "memory");
    GPIOR0 = 2;
    __asm__ volatile("" ::: "memory");
}

static inline void avr_mark_report(uint32_t items)
{
    GPIOR2 = (uint8_t)(items >> 24);
    GPIOR2 = (uint8_t)(items >> 16);
    GPIOR2 = (uint8_t)(items >> 8);
    GPIOR2 = (uint8_t)items;
    GPIOR0 = 3;
}

static inline void avr_mark_begin(const char *label)
{
    avr_mark_label(label);
    avr_mark_start();
}

static inline void avr_mark_end(uint32_t items)
{
    avr_mark_stop();
    avr_mark_report(items);
}

#endif
