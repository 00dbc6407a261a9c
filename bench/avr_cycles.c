/*
 * avr_cycles.c — exact cycle counts of AVR code under libsimavr.
 *
 *   avr_cycles PROGRAM.elf [TAG [PROFILE-LABEL]]
 *
 * Loads an AVR ELF (MCU and clock from its .mmcu section, default
 * atmega328p at 16 MHz), runs it to the end (sleep with interrupts off) and
 * prints one row per measurement the program reports through the GPIOR
 * markers of bench/avr/avr_mark.h: label, cycles, items, cycles per item.
 * The counts come from simavr's cycle counter, which is exact for the AVR
 * core (no caches, fixed instruction timings). With PROFILE-LABEL, the
 * cycles of that measurement are also attributed to the functions whose
 * instructions spent them (exact: the simulator is stepped one instruction
 * at a time; symbols from `avr-nm`), printed as a flat profile.
 * Host tool: libc and doubles.
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
    const char *profile;   /* label to profile, or NULL */
    int measuring;         /* between start and stop of the profiled label */
    uint64_t *hist;        /* cycles per flash word while measuring */
    char label[64];
    size_t len;
    avr_cycle_count_t t0;
    uint64_t acc, worst;   /* cycles of the start/stop pairs, longest pair */
    unsigned pairs;
    uint32_t items;
    int rows;
};

static void on_gpior0(struct avr_t *avr, avr_io_addr_t addr, uint8_t v, void *param)
{
    struct mark_state *m = param;
    avr->data[addr] = v;
    if (v == 1) {
        m->t0 = avr->cycle;
        m->measuring = m->profile && !strcmp(m->label, m->profile);
    } else if (v == 2) {
        uint64_t d = (uint64_t)(avr->cycle - m->t0);
        m->acc += d;
        m->worst = d > m->worst ? d : m->worst;
        m->pairs++;
        m->measuring = 0;
    } else if (v == 3 && m->label[0] == '=') {
        printf("%-8s %-30s %12lu\n", m->tag, m->label + 2, (unsigned long)m->items);
        m->len = 0;
        m->label[0] = '\0';
        m->items = 0;
    } else if (v == 3) {
        uint64_t cyc = m->acc;
        if (m->items == 0)
            printf("%-8s %-22s init failed or no output (%llu cycles)\n", m->tag, m->label,
                   (unsigned long long)cyc);
        else
            printf("%-8s %-22s %12llu %8lu %12.1f", m->tag, m->label, (unsigned long long)cyc,
                   (unsigned long)m->items, (double)cyc / m->items);
        if (m->pairs > 1)
            printf("   (%u calls, %.1f cycles/call, longest %llu)", m->pairs, (double)cyc / m->pairs,
                   (unsigned long long)m->worst);
        printf("\n");
        m->acc = 0;
        m->worst = 0;
        m->pairs = 0;
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

struct sym { unsigned long addr, size; char name[64]; };

static void print_profile(const char *elf, const char *label, const uint64_t *hist, size_t words)
{
    char cmd[512];
    struct sym syms[512];
    size_t ns = 0;
    snprintf(cmd, sizeof cmd, "avr-nm -n -S --defined-only '%s'", elf);
    FILE *p = popen(cmd, "r");
    char line[256];
    while (p && ns < 512 && fgets(line, sizeof line, p)) {
        char type;
        struct sym *y = &syms[ns];
        if (sscanf(line, "%lx %lx %c %63s", &y->addr, &y->size, &type, y->name) == 4 &&
            (type == 't' || type == 'T') && y->addr < 0x800000)
            ns++;
    }
    if (p)
        pclose(p);
    uint64_t total = 0, per[512] = { 0 }, other = 0;
    for (size_t w = 0; w < words; w++) {
        if (!hist[w])
            continue;
        total += hist[w];
        size_t k;
        for (k = 0; k < ns; k++)
            if (2 * w >= syms[k].addr && 2 * w < syms[k].addr + syms[k].size)
                break;
        if (k < ns)
            per[k] += hist[w];
        else
            other += hist[w];
    }
    printf("flat profile of \"%s\" (%llu cycles):\n", label, (unsigned long long)total);
    for (int shown = 0; shown < 12; shown++) {
        size_t best = ns;
        for (size_t k = 0; k < ns; k++)
            if (per[k] && (best == ns || per[k] > per[best]))
                best = k;
        if (best == ns)
            break;
        printf("  %5.1f%%  %10llu  %s\n", 100.0 * per[best] / total, (unsigned long long)per[best],
               syms[best].name);
        per[best] = 0;
    }
    if (other)
        printf("  %5.1f%%  %10llu  (no symbol)\n", 100.0 * other / total, (unsigned long long)other);
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
    m.profile = argc > 3 ? argv[3] : NULL;
    static uint64_t hist[32768]; /* 64 KB of flash, in words */
    m.hist = hist;
    avr_register_io_write(avr, GPIOR0_ADDR, on_gpior0, &m);
    avr_register_io_write(avr, GPIOR1_ADDR, on_gpior1, &m);
    avr_register_io_write(avr, GPIOR2_ADDR, on_gpior2, &m);
    int state = cpu_Running;
    /* A program that overflows its stack usually loops forever: give up
     * after max_cycles (~60 s of the 16 MHz part). */
    const avr_cycle_count_t max_cycles = 1000000000ull;
    while (state != cpu_Done && state != cpu_Crashed && avr->cycle < max_cycles) {
        avr_flashaddr_t pc = avr->pc;
        avr_cycle_count_t c0 = avr->cycle;
        state = avr_run(avr);
        if (m.measuring && pc / 2 < 32768)
            hist[pc / 2] += avr->cycle - c0;
    }
    if (state != cpu_Done || m.rows == 0) {
        fprintf(stderr, "avr_cycles: %s %s after %llu cycles, %d measurement(s)\n", argv[1],
                state == cpu_Crashed ? "crashed" : state == cpu_Done ? "ended" : "did not end (stack overflow?)", (unsigned long long)avr->cycle, m.rows);
        return 1;
    }
    if (m.profile)
        print_profile(argv[1], m.profile, hist, 32768);
    avr_terminate(avr);
    return 0;
}
