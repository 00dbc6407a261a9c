/*
 * avr_cycles.c — exact cycle counts of AVR code under libsimavr.
 *
 *   avr_cycles PROGRAM.elf [TAG]
 *
 * Loads an AVR ELF (MCU and clock from its .mmcu section, default
 * atmega328p at 16 MHz), runs it to the end (sleep with interrupts off) and
 * prints one row per measurement the program reports through the GPIOR
 * markers of bench/avr/avr_mark.h: label, cycles, items, cycles per item.
 * The counts come from simavr's cycle counter, which is exact for the AVR
 * core (no caches, fixed instruction timings). Host tool: libc and doubles.
 */
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>
#include "sim_avr.h"
#include "sim_elf.h"

/* simavr logs "Loaded N .text" etc. at info level: keep warnings and errors only. */
static void quiet_logger(struct avr_t *avr, const int level, const char *format, va_list ap)
{
    (void)avr;
    if (level <= LOG_WARNING)
        vfprintf(stderr, format, ap);
}

#define GPIOR0_ADDR 0x3E
#define GPIOR1_ADDR 0x4A
#define GPIOR2_ADDR 0x4B

struct mark_state {
    const char *tag;
    char label[64];
    size_t len;
    avr_cycle_count_t t0, t1;
    uint32_t items;
    int rows;
};

static void on_gpior0(struct avr_t *avr, avr_io_addr_t addr, uint8_t v, void *param)
{
    struct mark_state *m = param;
    avr->data[addr] = v;
    if (v == 1) {
        m->t0 = avr->cycle;
    } else if (v == 2) {
        m->t1 = avr->cycle;
    } else if (v == 3) {
        uint64_t cyc = (uint64_t)(m->t1 - m->t0);
        printf("%-8s %-22s %12llu %8lu %12.1f\n", m->tag, m->label, (unsigned long long)cyc,
               (unsigned long)m->items, m->items ? (double)cyc / m->items : 0.0);
        m->rows++;
        m->len = 0;
        m->label[0] = '\0';
        m->items = 0;
    }
}

static void on_gpior1(struct avr_t *avr, avr_io_addr_t addr, uint8_t v, void *param)
{
    struct mark_state *m = param;
    avr->data[addr] = v;
    if (m->len + 1 < sizeof m->label) {
        m->label[m->len++] = (char)v;
        m->label[m->len] = '\0';
    }
}

static void on_gpior2(struct avr_t *avr, avr_io_addr_t addr, uint8_t v, void *param)
{
    struct mark_state *m = param;
    avr->data[addr] = v;
    m->items = (m->items << 8) | v;
}

int main(int argc, char **argv)
{
    if (argc < 2) {
        fprintf(stderr, "usage: avr_cycles PROGRAM.elf [TAG]\n");
        return 2;
    }
    avr_global_logger_set(quiet_logger);
    elf_firmware_t fw;
    memset(&fw, 0, sizeof fw);
    if (elf_read_firmware(argv[1], &fw) != 0) {
        fprintf(stderr, "avr_cycles: cannot read %s\n", argv[1]);
        return 1;
    }
    if (!fw.mmcu[0])
        strcpy(fw.mmcu, "atmega328p");
    if (!fw.frequency)
        fw.frequency = 16000000;
    avr_t *avr = avr_make_mcu_by_name(fw.mmcu);
    if (!avr) {
        fprintf(stderr, "avr_cycles: unknown MCU %s\n", fw.mmcu);
        return 1;
    }
    avr_init(avr);
    avr_load_firmware(avr, &fw);
    struct mark_state m;
    memset(&m, 0, sizeof m);
    m.tag = argc > 2 ? argv[2] : fw.mmcu;
    avr_register_io_write(avr, GPIOR0_ADDR, on_gpior0, &m);
    avr_register_io_write(avr, GPIOR1_ADDR, on_gpior1, &m);
    avr_register_io_write(avr, GPIOR2_ADDR, on_gpior2, &m);
    int state = cpu_Running;
    while (state != cpu_Done && state != cpu_Crashed)
        state = avr_run(avr);
    if (state == cpu_Crashed || m.rows == 0) {
        fprintf(stderr, "avr_cycles: %s %s after %llu cycles, %d measurement(s)\n", argv[1],
                state == cpu_Crashed ? "crashed" : "ended", (unsigned long long)avr->cycle, m.rows);
        return 1;
    }
    avr_terminate(avr);
    return 0;
}
