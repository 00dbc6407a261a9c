/*
 * avr_chip.c — an emulated AVR board on libsimavr (see avr_chip.h).
 *
 * Built with PK_HAVE_SIMAVR (and simavr's include paths) when pkg-config
 * finds simavr (host-sim's Makefile lines); otherwise only the board table
 * and the "not available" answers are compiled.
 */
#include "avr_chip.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* The boards of hal/avr/: keep in step with their board.h. */
const struct pk_avrchip_board pk_avrchip_boards[] = {
    {
        .name = "uno-cnc-shield", .mcu = "atmega328p", .f_cpu = 16000000u, .ram_start = 0x100, .axes = 3,
        .step = { { 'D', 2 }, { 'D', 3 }, { 'D', 4 } },
        .dir = { { 'D', 5 }, { 'D', 6 }, { 'D', 7 } },
        .enable = { { 'B', 0 } }, .shared_enable = 1, .enable_invert = 7u,
        .servo = { 'B', 3 }, .servo_min_us = 1000u, .servo_max_us = 2000u,
        .step_vector = 11, .step_timsk = 0x6F, .step_ocie = 1,
    },
    {
        .name = "mega-ramps", .mcu = "atmega2560", .f_cpu = 16000000u, .ram_start = 0x200, .axes = 3,
        .step = { { 'F', 0 }, { 'F', 6 }, { 'L', 3 } },
        .dir = { { 'F', 1 }, { 'F', 7 }, { 'L', 1 } },
        .enable = { { 'D', 7 }, { 'F', 2 }, { 'K', 0 } }, .shared_enable = 0, .enable_invert = 7u,
        .servo = { 'B', 5 }, .servo_min_us = 1000u, .servo_max_us = 2000u,
        .step_vector = 32, .step_timsk = 0x71, .step_ocie = 1,
        /* limits: X min D3 PE5, Y min D14 PJ1, Z min D18 PD3; probe: Z max D19 PD2 */
        .input = { { 'E', 5 }, { 'J', 1 }, { 'D', 3 }, { 0, 0 }, { 'D', 2 } },
        .input_invert = 0x17u,
        /* PJ1 = PCINT10: group 1 (PCICR 0x68 bit PCIE1, PCIFR 0x3B, PCMSK1 0x6C), vector 10 */
        .pcx = { .port = 'J', .shift = 1, .vector = 10, .pcie = 1, .pcif = 1,
                 .pcicr = 0x68, .pcmsk = 0x6C, .pcifr = 0x3B },
    },
    { .name = NULL },
};

const struct pk_avrchip_board *pk_avrchip_board_find(const char *name)
{
    for (const struct pk_avrchip_board *b = pk_avrchip_boards; b->name != NULL; b++)
        if (strcmp(b->name, name) == 0)
            return b;
    return NULL;
}

const char *pk_avrchip_missing_text(void)
{
    return "this build of plotkin has no simavr: install it (as root: bash .ci/deps.sh targets,\n"
           "or apt-get install simavr libsimavr-dev libelf-dev), then rebuild (make)";
}

#ifndef PK_HAVE_SIMAVR

int pk_avrchip_available(void) { return 0; }

int pk_avrchip_open(struct pk_avrchip *c, const struct pk_avrchip_board *b, const char *hex_path,
                    char *err, size_t errlen)
{
    (void)b;
    (void)hex_path;
    memset(c, 0, sizeof *c);
    snprintf(err, errlen, "%s", pk_avrchip_missing_text());
    return -1;
}
void pk_avrchip_close(struct pk_avrchip *c) { (void)c; }
uint64_t pk_avrchip_cycles(const struct pk_avrchip *c) { (void)c; return 0; }
int pk_avrchip_run_until(struct pk_avrchip *c, uint64_t until)
{
    (void)c;
    (void)until;
    return -1;
}
const char *pk_avrchip_state_text(const struct pk_avrchip *c)
{
    (void)c;
    return "no simavr";
}
int pk_avrchip_uart_send(struct pk_avrchip *c, uint8_t byte)
{
    (void)c;
    (void)byte;
    return 0;
}
void pk_avrchip_emit_initial(struct pk_avrchip *c) { (void)c; }
long pk_avrchip_eeprom(struct pk_avrchip *c, uint8_t *buf, size_t n, int set)
{
    (void)c;
    (void)buf;
    (void)n;
    (void)set;
    return -1;
}
void pk_avrchip_input_set(struct pk_avrchip *c, unsigned input, int active)
{
    (void)c;
    (void)input;
    (void)active;
}
unsigned pk_avrchip_stack_bytes(const struct pk_avrchip *c)
{
    (void)c;
    return 0;
}
unsigned pk_avrchip_ram_bytes(const struct pk_avrchip *c)
{
    (void)c;
    return 0;
}
int pk_avrchip_track_fn(struct pk_avrchip *c, const char *name, uint32_t addr)
{
    (void)c;
    (void)name;
    (void)addr;
    return -1;
}
unsigned pk_avrchip_isr_response(const struct pk_avrchip *c)
{
    (void)c;
    return 0;
}
int pk_avrchip_watch(struct pk_avrchip *c, const char *name, uint16_t addr)
{
    (void)c;
    (void)name;
    (void)addr;
    return -1;
}
int pk_avrchip_peek(const struct pk_avrchip *c, uint16_t addr, void *out, size_t n)
{
    (void)c;
    (void)addr;
    (void)out;
    (void)n;
    return -1;
}

#else

#include <stdarg.h>
#include "avr_eeprom.h"
#include "avr_ioport.h"
#include "avr_uart.h"
#include "sim_avr.h"
#include "sim_hex.h"
#include "sim_interrupts.h"
#include "sim_irq.h"

int pk_avrchip_available(void) { return 1; }

/* simavr logs loading and peripheral notes at info level: keep errors. */
static void quiet_logger(struct avr_t *avr, const int level, const char *format, va_list ap)
{
    (void)avr;
    if (level <= LOG_ERROR)
        vfprintf(stderr, format, ap);
}

#define TAP_STEP 0u
#define TAP_DIR 1u
#define TAP_EN 2u
#define TAP_SERVO 3u

static avr_t *AV(const struct pk_avrchip *c) { return (avr_t *)c->avr; }

static void emit(struct pk_avrchip *c, uint64_t t, enum pk_sig_kind kind, unsigned axis, int level,
                 int initial)
{
    c->edges++;
    if (c->on_edge != NULL) {
        struct pk_trace_edge e = { t, (uint8_t)kind, (uint8_t)axis, (uint8_t)level, (uint8_t)initial };
        c->on_edge(c->on_edge_arg, &e);
    }
}

/* The servo pin: a rising edge starts a pulse, the falling edge measures it.
 * The pen level changes at the rising edge of the first pulse of the other
 * half of the range (beyond 4 us of its middle). */
static void servo_edge(struct pk_avrchip *c, uint64_t t, int level)
{
    if (level) {
        if (c->servo_rise != 0u) {
            uint64_t period = t - c->servo_rise;
            if (c->servo_pulses > 1u) {
                if (c->servo_period_min == 0u || period < c->servo_period_min)
                    c->servo_period_min = period;
                if (period > c->servo_period_max)
                    c->servo_period_max = period;
            }
        }
        c->servo_prev_rise = c->servo_rise;
        c->servo_rise = t;
        return;
    }
    if (c->servo_rise == 0u)
        return;
    uint64_t w = t - c->servo_rise;
    c->servo_pulses++;
    c->servo_width_last = w;
    uint64_t tol = 4u * (c->b->f_cpu / 1000000u);
    uint64_t prev = c->n_servo_widths ? c->servo_widths[c->n_servo_widths - 1u] : 0u;
    if (c->n_servo_widths < 16u && (c->n_servo_widths == 0u || (w > prev ? w - prev : prev - w) > tol))
        c->servo_widths[c->n_servo_widths++] = w;
    if (c->servo_width_min == 0u || w < c->servo_width_min)
        c->servo_width_min = w;
    if (w > c->servo_width_max)
        c->servo_width_max = w;
    uint64_t mid = (uint64_t)(c->b->servo_min_us + c->b->servo_max_us) * (c->b->f_cpu / 1000000u) / 2u;
    /* a pulse within tol of the middle keeps the level: a value at half range
     * would otherwise flip it with every cycle of interrupt latency */
    int pen = c->pen < 0 ? w > mid : w > mid + tol ? 1 : w + tol < mid ? 0 : c->pen;
    if (pen != c->pen) {
        /* the first pulse only tells where the pen starts */
        emit(c, c->servo_rise, PK_SIG_PEN, 0, pen, c->pen < 0);
        c->pen = pen;
    }
}

static void pin_notify(struct avr_irq_t *irq, uint32_t value, void *param)
{
    (void)irq;
    struct pk_avrchip_tap *tap = param;
    struct pk_avrchip *c = tap->c;
    unsigned idx = (unsigned)(tap - c->taps);
    uint8_t lv = (uint8_t)(value & 1u);
    if (c->level[idx] == lv)
        return;
    c->level[idx] = lv;
    uint64_t t = AV(c)->cycle;
    switch (tap->kind) {
    case TAP_STEP: emit(c, t, PK_SIG_STEP, tap->axis, lv, 0); break;
    case TAP_DIR: emit(c, t, PK_SIG_DIR, tap->axis, lv, 0); break;
    case TAP_EN: emit(c, t, PK_SIG_ENABLE, tap->axis, lv, 0); break;
    default: servo_edge(c, t, lv); break;
    }
}

static void uart_out(struct avr_irq_t *irq, uint32_t value, void *param)
{
    (void)irq;
    struct pk_avrchip *c = param;
    if (c->n_out == c->cap_out) {
        size_t cap = c->cap_out ? 2 * c->cap_out : 4096;
        uint8_t *p = realloc(c->out, cap);
        if (p == NULL)
            return;
        c->out = p;
        c->cap_out = cap;
    }
    c->out[c->n_out++] = (uint8_t)value;
    c->bytes_out++;
}

static void uart_xoff(struct avr_irq_t *irq, uint32_t value, void *param)
{
    (void)irq;
    ((struct pk_avrchip *)param)->rx_full = value != 0;
}

static void uart_xon(struct avr_irq_t *irq, uint32_t value, void *param)
{
    (void)irq;
    if (value)
        ((struct pk_avrchip *)param)->rx_full = 0;
}

static int tap(struct pk_avrchip *c, unsigned idx, struct pk_avrchip_pin pin, uint8_t kind,
               uint8_t axis)
{
    if (pin.port == 0)
        return 0;
    avr_irq_t *irq = avr_io_getirq(AV(c), AVR_IOCTL_IOPORT_GETIRQ(pin.port), pin.bit);
    if (irq == NULL)
        return -1;
    c->taps[idx] = (struct pk_avrchip_tap){ c, kind, axis };
    avr_irq_register_notify(irq, pin_notify, &c->taps[idx]);
    return 0;
}

/* Drive the input pins to the levels asked for (outside every interrupt:
 * see pk_avrchip_input_set). */
static void inputs_apply(struct pk_avrchip *c)
{
    avr_t *avr = AV(c);
    const struct pk_avrchip_board *b = c->b;
    uint32_t changed = c->in_want ^ c->in_have;
    for (unsigned i = 0; i < PK_AVRCHIP_INPUTS; i++) {
        struct pk_avrchip_pin pin = b->input[i];
        if (pin.port == 0 || !(changed >> i & 1u))
            continue;
        uint32_t raw = ((c->in_want ^ b->input_invert) >> i) & 1u;
        avr_raise_irq(avr_io_getirq(avr, AVR_IOCTL_IOPORT_GETIRQ(pin.port), pin.bit), raw);
        c->input_edges++;
        if (pin.port == b->pcx.port && c->pcx_vec != NULL && (avr->data[b->pcx.pcicr] >> b->pcx.pcie & 1u) &&
            (avr->data[b->pcx.pcmsk] >> (pin.bit + b->pcx.shift) & 1u))
            avr_raise_interrupt(avr, (avr_int_vector_t *)c->pcx_vec);
    }
    c->in_have = c->in_want;
    c->in_dirty = 0;
}

long pk_avrchip_eeprom(struct pk_avrchip *c, uint8_t *buf, size_t n, int set)
{
    avr_t *avr = AV(c);
    size_t size = (size_t)avr->e2end + 1u;
    if (n > size)
        return -1;
    if (n == 0)
        return (long)size;
    /* simavr 1.6's EEPROM_SET/GET refuse a range that reaches the last byte
     * (">= size"), return -1 even when they succeed and SET prints to stdout;
     * GET with no buffer hands out the EEPROM itself, which is used both ways. */
    avr_eeprom_desc_t d = { .ee = NULL, .offset = 0, .size = 0 };
    (void)avr_ioctl(avr, AVR_IOCTL_EEPROM_GET, &d);
    if (d.ee == NULL)
        return -1;
    if (set)
        memcpy(d.ee, buf, n);
    else
        memcpy(buf, d.ee, n);
    return (long)size;
}

void pk_avrchip_input_set(struct pk_avrchip *c, unsigned input, int active)
{
    if (input >= PK_AVRCHIP_INPUTS || c->b->input[input].port == 0)
        return;
    c->in_want = active ? c->in_want | 1u << input : c->in_want & ~(1u << input);
    c->in_dirty = c->in_want != c->in_have;
}

int pk_avrchip_open(struct pk_avrchip *c, const struct pk_avrchip_board *b, const char *hex_path,
                    char *err, size_t errlen)
{
    memset(c, 0, sizeof *c);
    c->b = b;
    c->pen = -1;
    avr_global_logger_set(quiet_logger);
    avr_t *avr = avr_make_mcu_by_name(b->mcu);
    if (avr == NULL) {
        snprintf(err, errlen, "simavr does not know the part %s", b->mcu);
        return -1;
    }
    c->avr = avr;
    avr_init(avr);
    avr->frequency = b->f_cpu;
    ihex_chunk_p chunks = NULL;
    int n = read_ihex_chunks(hex_path, &chunks);
    if (n <= 0) {
        snprintf(err, errlen, "%s: not a readable Intel HEX file", hex_path);
        pk_avrchip_close(c);
        return -1;
    }
    for (int i = 0; i < n; i++) {
        if (chunks[i].baseaddr + chunks[i].size > (uint32_t)avr->flashend + 1u) {
            snprintf(err, errlen, "%s: %u bytes at 0x%x do not fit the %s's %u bytes of flash",
                     hex_path, chunks[i].size, chunks[i].baseaddr, b->mcu, avr->flashend + 1u);
            free_ihex_chunks(chunks);
            pk_avrchip_close(c);
            return -1;
        }
        avr_loadcode(avr, chunks[i].data, chunks[i].size, chunks[i].baseaddr);
    }
    free_ihex_chunks(chunks);
    avr->pc = 0;

    uint32_t flags = 0;
    avr_ioctl(avr, AVR_IOCTL_UART_GET_FLAGS('0'), &flags);
    flags &= ~(uint32_t)AVR_UART_FLAG_STDIO;
    avr_ioctl(avr, AVR_IOCTL_UART_SET_FLAGS('0'), &flags);
    avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUTPUT), uart_out, c);
    avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUT_XOFF), uart_xoff, c);
    avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUT_XON), uart_xon, c);

    int rc = 0;
    for (unsigned a = 0; a < b->axes; a++) {
        rc |= tap(c, a, b->step[a], TAP_STEP, (uint8_t)a);
        rc |= tap(c, PK_AVRCHIP_MAX_AXES + a, b->dir[a], TAP_DIR, (uint8_t)a);
        if (a == 0 || !b->shared_enable)
            rc |= tap(c, 2 * PK_AVRCHIP_MAX_AXES + a, b->enable[a], TAP_EN, (uint8_t)a);
    }
    rc |= tap(c, 3 * PK_AVRCHIP_MAX_AXES, b->servo, TAP_SERVO, 0);
    if (rc != 0) {
        snprintf(err, errlen, "simavr's %s has no port for a pin of board %s", b->mcu, b->name);
        pk_avrchip_close(c);
        return -1;
    }
    if (b->pcx.port != 0) {
        avr_int_vector_t *v = calloc(1, sizeof *v);
        if (v == NULL) {
            snprintf(err, errlen, "out of memory");
            pk_avrchip_close(c);
            return -1;
        }
        v->enable = (avr_regbit_t)AVR_IO_REGBIT(b->pcx.pcicr, b->pcx.pcie);
        v->raised = (avr_regbit_t)AVR_IO_REGBIT(b->pcx.pcifr, b->pcx.pcif);
        v->vector = b->pcx.vector;
        avr_register_vector(avr, v);
        c->pcx_vec = v;
    }
    /* every wired input starts released: its pull-up level */
    c->in_have = ~0u;
    c->in_want = 0u;
    inputs_apply(c);
    c->input_edges = 0;
    c->sp_min = 0xFFFFu;
    c->state = cpu_Running;
    return 0;
}

void pk_avrchip_close(struct pk_avrchip *c)
{
    if (c->avr != NULL)
        avr_terminate(AV(c));
    c->avr = NULL;
    free(c->pcx_vec);
    c->pcx_vec = NULL;
    free(c->out);
    c->out = NULL;
    c->n_out = c->cap_out = 0;
}

uint64_t pk_avrchip_cycles(const struct pk_avrchip *c) { return AV(c)->cycle; }

unsigned pk_avrchip_isr_response(const struct pk_avrchip *c)
{
    return AV(c)->address_size > 2 ? 5u : 4u;
}

static uint16_t sp_of(const avr_t *avr)
{
    return (uint16_t)(avr->data[R_SPL] | (avr->data[R_SPH] << 8));
}

/* The return address (a byte address in flash) on top of the stack at sp:
 * pushed high byte last, so it starts at SP + 1, address_size bytes. */
static uint32_t ret_at(const avr_t *avr, uint16_t sp)
{
    uint32_t ra = 0;
    for (unsigned k = 1; k <= avr->address_size; k++)
        ra = (ra << 8) | avr->data[(uint16_t)(sp + k)];
    return 2u * ra;
}

/* The main-loop histogram with library routines charged to their callers:
 * a shadow stack of the calls under way at the main level (CALL, RCALL,
 * ICALL, EICALL), unwound by RET to the entry whose return address it
 * reached (read from the stack before the RET runs, since an interrupt may
 * be entered in the same step; a RET that matches none, such as a computed
 * jump through the stack, leaves the stack alone). hist_site gives the
 * address to charge pc0's cycles to: pc0 itself in the image's own code; in a
 * library routine, the innermost call made from the image's own code. */
static avr_flashaddr_t hist_site(const struct pk_avrchip *c, avr_flashaddr_t pc0)
{
    if (c->hist_lib[pc0 / 2u])
        for (unsigned k = c->hist_depth; k > 0; k--) {
            uint32_t site = c->hist_site[k - 1] & 0x7FFFFFFFu;
            if (!c->hist_lib[site / 2u])
                return site;
        }
    return pc0;
}

/* Before the instruction at pc0 runs: its kind (4 or 2: a call of that
 * size, 1: a RET, 0: other) and, for a RET, where it returns to (*ret). */
static int hist_op(const avr_t *avr, avr_flashaddr_t pc0, uint32_t *ret)
{
    const uint16_t op = (uint16_t)(avr->flash[pc0] | (avr->flash[pc0 + 1u] << 8));
    if ((op & 0xFE0Eu) == 0x940Eu)
        return 4;
    if ((op & 0xF000u) == 0xD000u || op == 0x9509u || op == 0x9519u)
        return 2;
    if (op != 0x9508u)
        return 0;
    *ret = ret_at(avr, sp_of(avr));
    return 1;
}

static void hist_track(struct pk_avrchip *c, avr_flashaddr_t pc0, int kind, uint32_t ret)
{
    if (kind >= 2 && c->hist_depth < sizeof c->hist_site / sizeof c->hist_site[0]) {
        c->hist_site[c->hist_depth++] = (uint32_t)pc0 | (uint32_t)(kind == 4) << 31;
    } else if (kind == 1) {
        for (unsigned k = c->hist_depth; k > 0; k--) {
            uint32_t e = c->hist_site[k - 1];
            if ((e & 0x7FFFFFFFu) + ((e >> 31) ? 4u : 2u) == ret) {
                c->hist_depth = (uint8_t)(k - 1);
                break;
            }
        }
    }
}

/* One instruction (plus whatever interrupt it let in), and the bookkeeping. */
static void step(struct pk_avrchip *c)
{
    avr_t *avr = AV(c);
    uint8_t depth0 = avr->interrupts.running_ptr;
    avr_cycle_count_t cyc0 = avr->cycle;
    avr_flashaddr_t pc0 = avr->pc;
    uint32_t ret = 0;
    const int track = c->hist != NULL && c->hist_main && c->hist_lib != NULL && depth0 == 0;
    const int kind = track ? hist_op(avr, pc0, &ret) : 0;
    const avr_flashaddr_t site = track ? hist_site(c, pc0) : pc0;
    c->state = avr_run(avr);
    if (track)
        hist_track(c, pc0, kind, ret);
    uint16_t sp = sp_of(avr);
    if (sp < c->sp_min)
        c->sp_min = sp;
    uint8_t depth = avr->interrupts.running_ptr;
    uint8_t cur = c->n_frames ? c->frames[c->n_frames - 1].vec : 0xFFu;
    if (c->hist != NULL && pc0 / 2u < c->hist_words
        && (c->hist_main ? depth0 == 0 && depth == 0
                         : depth0 > 0 && cur == c->b->step_vector)) {
        c->hist[site / 2u] += avr->cycle - cyc0;
    }
    if (depth > depth0 && c->n_frames < sizeof c->frames / sizeof c->frames[0]) {
        /* entered: the vector's first instruction runs next */
        c->frames[c->n_frames++] = (struct pk_avrchip_frame){
            (uint8_t)avr->interrupts.running[depth - 1]->vector, avr->cycle, 0 };
    } else if (depth < depth0 && c->n_frames > 0) {
        struct pk_avrchip_frame f = c->frames[--c->n_frames];
        uint64_t incl = avr->cycle - f.t0 + pk_avrchip_isr_response(c);
        uint64_t excl = incl - f.nested;
        if (f.vec < PK_AVRCHIP_VECTORS) {
            struct pk_avrchip_isr *st = &c->isr[f.vec];
            st->calls++;
            st->cycles += excl;
            if (excl > st->max)
                st->max = excl;
            if (incl > st->max_incl)
                st->max_incl = incl;
        }
        if (c->n_frames > 0)
            c->frames[c->n_frames - 1].nested += incl;
        else
            c->isr_cycles_total += incl;
        c->nest_acc[c->n_frames] += incl;
    }
    uint8_t timsk = avr->data[c->b->step_timsk] & (uint8_t)(1u << c->b->step_ocie);
    int in_step = 0;
    for (unsigned i = 0; i < c->n_frames; i++)
        in_step |= c->frames[i].vec == c->b->step_vector;
    if (timsk && !c->timsk_last && !in_step)
        c->timer_starts++;
    c->timsk_last = timsk;
    for (unsigned i = 0; i < c->n_fn; i++) {
        struct pk_avrchip_fn *f = &c->fn[i];
        if (f->active) {
            /* returned: back at the return address with the stack above
             * it. SP alone is not enough: a prologue or epilogue writes SPH
             * and SPL one at a time, and the value between the two writes
             * can lie above the entry SP (a frame of 256 B or more freed). */
            if (c->n_frames == f->level && sp > f->sp && avr->pc == f->ret) {
                uint64_t cyc = (avr->cycle - f->t0) - (c->nest_acc[f->level] - f->isr0);
                f->active = 0;
                f->calls++;
                f->cycles += cyc;
                if (cyc > f->max) {
                    f->max = cyc;
                    f->max_t0 = f->t0;
                }
            }
        } else if (avr->pc == f->addr) {
            f->active = 1;
            f->level = c->n_frames;
            f->sp = sp;
            f->ret = ret_at(avr, sp);
            f->t0 = avr->cycle;
            f->isr0 = c->nest_acc[f->level];
        }
    }
    for (unsigned i = 0; i < c->n_watch; i++) {
        struct pk_avrchip_watch *w = &c->watch[i];
        uint8_t v = avr->data[w->addr];
        if (v != w->last) {
            w->changes++;
            w->last = v;
        }
    }
}

int pk_avrchip_run_until(struct pk_avrchip *c, uint64_t until)
{
    avr_t *avr = AV(c);
    while (avr->cycle < until) {
        if (c->state != cpu_Running && c->state != cpu_Sleeping && c->state != cpu_Step &&
            c->state != cpu_StepDone)
            return -1;
        if (c->in_dirty && c->n_frames == 0)
            inputs_apply(c);
        step(c);
    }
    return (c->state == cpu_Done || c->state == cpu_Crashed) ? -1 : 0;
}

const char *pk_avrchip_state_text(const struct pk_avrchip *c)
{
    switch (c->state) {
    case cpu_Running: return "running";
    case cpu_Sleeping: return "sleeping";
    case cpu_Done: return "stopped (sleep with interrupts off)";
    case cpu_Crashed: return "crashed";
    default: return "stopped";
    }
}

int pk_avrchip_uart_send(struct pk_avrchip *c, uint8_t byte)
{
    if (c->rx_full)
        return 0;
    avr_raise_irq(avr_io_getirq(AV(c), AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_INPUT), byte);
    c->bytes_in++;
    return 1;
}

void pk_avrchip_emit_initial(struct pk_avrchip *c)
{
    uint64_t t = AV(c)->cycle;
    for (unsigned a = 0; a < c->b->axes; a++) {
        emit(c, t, PK_SIG_STEP, a, c->level[a], 1);
        emit(c, t, PK_SIG_DIR, a, c->level[PK_AVRCHIP_MAX_AXES + a], 1);
        if (a == 0 || !c->b->shared_enable)
            emit(c, t, PK_SIG_ENABLE, a, c->level[2 * PK_AVRCHIP_MAX_AXES + a], 1);
    }
    emit(c, t, PK_SIG_PEN, 0, 0, 1);
}

unsigned pk_avrchip_stack_bytes(const struct pk_avrchip *c)
{
    const avr_t *avr = AV(c);
    return c->sp_min > avr->ramend ? 0u : (unsigned)(avr->ramend - c->sp_min);
}

unsigned pk_avrchip_ram_bytes(const struct pk_avrchip *c)
{
    return (unsigned)AV(c)->ramend + 1u - c->b->ram_start;
}

int pk_avrchip_track_fn(struct pk_avrchip *c, const char *name, uint32_t addr)
{
    if (c->n_fn >= PK_AVRCHIP_MAX_FN)
        return -1;
    c->fn[c->n_fn++] = (struct pk_avrchip_fn){ .name = name, .addr = addr };
    return 0;
}

int pk_avrchip_watch(struct pk_avrchip *c, const char *name, uint16_t addr)
{
    if (c->n_watch >= PK_AVRCHIP_MAX_WATCH || addr > AV(c)->ramend)
        return -1;
    c->watch[c->n_watch++] = (struct pk_avrchip_watch){ name, addr, AV(c)->data[addr], 0 };
    return 0;
}

int pk_avrchip_peek(const struct pk_avrchip *c, uint16_t addr, void *out, size_t n)
{
    if ((size_t)addr + n > (size_t)AV(c)->ramend + 1u)
        return -1;
    memcpy(out, AV(c)->data + addr, n);
    return 0;
}

#endif
