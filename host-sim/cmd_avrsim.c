/*
 * cmd_avrsim.c — `plotkin avrsim FIRMWARE.hex`: the very image `make
 * firmware` builds, run on an emulated AVR board (avr_chip.h, libsimavr),
 * either streaming a G-code program into its serial port as a Grbl sender
 * does (--run) or bridging that port to a pseudo-terminal for a real sender
 * (--link). The board's pins are decoded with the host simulator's decoder
 * and driver-timing checks (sim_trace.h), so the summary can be set beside
 * `plotkin sim`'s.
 */
#include <ctype.h>
#include <errno.h>
#include <inttypes.h>
#include <math.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>
#include "avr_chip.h"
#include "commands.h"
#include "posix/pk_serial.h"
#include "sim_inputs.h"
#include "sim_trace.h"

static const char avrsim_usage[] =
    "usage: plotkin avrsim FIRMWARE.hex [--board NAME] --run PROGRAM [--config FILE] [--json]\n"
    "                      [--trace OUT.csv] [--at SECONDS:EVENT]... [--timeout SECONDS]\n"
    "                      [--driver NAME] [--elf FILE [--profile]] [--watch N:ADDR]...\n"
    "                      [--peek N:ADDR:BYTES]... [--input T:NAME=V]... [--switch NAME:AXIS:MM[:-]]...\n"
    "                      [--eeprom FILE] [--poll-status HZ]\n"
    "       plotkin avrsim FIRMWARE.hex [--board NAME] --link PATH [--speed X]\n"
    "\n"
    "Runs the Intel HEX image of a board (what `make firmware` writes, what would be\n"
    "flashed) on an emulated AVR at its clock (libsimavr, cycle-exact), and decodes\n"
    "its step/dir/enable pins and the pen servo's pulses.\n"
    "\n"
    "  --board NAME     uno-cnc-shield (ATmega328P, default) or mega-ramps (ATmega2560)\n"
    "  --run PROGRAM    stream a G-code file into the serial port with Grbl character\n"
    "                   counting (128-byte buffer), wait until the machine is idle, print\n"
    "                   a summary like `plotkin sim`'s (--json: one JSON object)\n"
    "  --config FILE    `$N=value` lines sent first, each waiting for its answer\n"
    "  --at S:EVENT     at S seconds (emulated) after the program starts, send a realtime\n"
    "                   byte: hold (!), resume (~), reset (ctrl-X), status (?); after a\n"
    "                   reset nothing more of the program is sent\n"
    "  --trace OUT.csv  every pin edge (tick = CPU cycle)\n"
    "  --driver NAME    timing limits checked: drv8825 (default), a4988, tmc2209\n"
    "  --elf FILE       the image's ELF (symbols): also measure the main-loop functions;\n"
    "                   --profile adds a flat cycle profile of the step interrupt;\n"
    "                   --hist FILE writes its cycles per flash address (`ADDR CYCLES`)\n"
    "                   (--hist-main FILE: the main loop's cycles instead, a library\n"
    "                   routine's (libgcc, libc) charged to the call that entered it;\n"
    "                   --charge-caller NAME: NAME's too, up to 12);\n"
    "                   --fn NAME also measures the function NAME (or NAME.*: a local\n"
    "                   of the link-time optimiser) outside interrupts, up to 12 of them\n"
    "  --watch N:ADDR   count the changes of the RAM byte at data address ADDR\n"
    "  --peek N:ADDR:B  report the B-byte little-endian value at ADDR at the end\n"
    "  --input T:NAME=V at T seconds after the program starts, the board's input NAME\n"
    "                   (limit-x limit-y limit-z probe ...) takes logical level V\n"
    "  --switch NAME:AXIS:MM[:-]  input NAME is active while the decoded AXIS is at MM\n"
    "                   or beyond (:- below), as `plotkin sim --switch`; mm with the\n"
    "                   steps/mm of --config ($100-$102, default 80)\n"
    "  --poll-status HZ send '?' at HZ as a sender polls (the next once the last report\n"
    "                   is in) and report the time from each '?' to its whole report\n"
    "  --eeprom FILE    the chip's EEPROM (settings, offsets, startup lines) is read from\n"
    "                   FILE before the chip starts (if it exists) and written back at the\n"
    "                   end, as the EEPROM of a board survives a power cycle\n"
    "  --link PATH      make a pseudo-terminal, symlink PATH to it and connect it to the\n"
    "                   emulated serial port until SIGINT/SIGTERM; --speed X runs the\n"
    "                   emulation X times real time at most (default 1; 0 = as fast as it can)\n"
    "\n"
    "Exit status: 0 ran cleanly; 1 the chip stopped or crashed, a timeout, G-code errors,\n"
    "alarms or timing violations; 2 bad usage or simavr missing.\n";

/* ---- one emulated board and what is decoded from it ------------------------ */

#define AT_MAX 16
#define ERR_MAX 16

struct at_event {
    double t_s;
    uint8_t byte;
    const char *name;
};

struct avrsim {
    struct pk_avrchip chip;
    const struct pk_avrchip_board *b;
    struct pk_decoder dec;
    struct pk_decoded res;
    FILE *csv;
    uint64_t first_step, last_step, last_edge_t;
    uint64_t steps_total;
    unsigned pen_changes;
    /* firmware output, line by line */
    size_t out_done;
    char line[512];
    size_t line_n;
    unsigned greetings, oks, errors, alarms, msgs;
    char msg_text[8][96];      /* the first 8 [..] lines */
    char set_text[64][24];     /* the first 64 $N=V lines ($$) */
    unsigned n_set;
    unsigned err_line[ERR_MAX], err_code[ERR_MAX];
    unsigned alarm_code;
    char status[256];          /* last status report */
    unsigned statuses;
    uint64_t status_seq;
    /* --poll-status: '?' at a sender's rate, the time to each whole report */
    uint64_t poll_cycles;      /* period, cycles (0: off) */
    uint64_t poll_next, poll_sent;
    int poll_waiting;
    double *lat_ms;            /* latencies (malloc'd) */
    size_t n_lat, cap_lat;
    /* sender */
    unsigned answered;         /* ok/error lines since the stream started */
    double spmm[3];
    /* inputs: scripted edges and switches along the decoded axes */
    struct pk_sim_inputs in;
    int64_t sw_pos[3];         /* decoded position, steps */
    int resolved;
};

/* Switch levels from the decoded position (switches only: timed edges are
 * applied by the program loop). */
static void switches_update(struct avrsim *s)
{
    for (size_t i = 0; i < s->in.n; i++) {
        const struct pk_sim_input *w = &s->in.in[i];
        if (!w->is_switch || w->axis >= 3)
            continue;
        int64_t p = s->sw_pos[w->axis];
        int on = w->side > 0 ? p >= w->at_steps : p <= w->at_steps;
        pk_avrchip_input_set(&s->chip, w->input, on);
    }
}

static void on_step(void *arg, const struct pk_step_event *ev)
{
    struct avrsim *s = arg;
    if (s->steps_total++ == 0)
        s->first_step = ev->t;
    s->last_step = ev->t;
    if (ev->axis < 3) {
        s->sw_pos[ev->axis] += ev->dir;
        if (s->resolved)
            switches_update(s);
    }
}

static void on_edge(void *arg, const struct pk_trace_edge *e)
{
    struct avrsim *s = arg;
    if (e->kind == PK_SIG_PEN && !e->initial)
        s->pen_changes++;
    s->last_edge_t = e->t;
    (void)pk_decoder_push(&s->dec, e);
    if (s->csv != NULL)
        pk_trace_csv_row(s->csv, e, s->b->f_cpu, s->b->shared_enable);
}

static void handle_line(struct avrsim *s, const char *l)
{
    if (strcmp(l, "ok") == 0) {
        s->oks++;
        s->answered++;
    } else if (strncmp(l, "error:", 6) == 0) {
        if (s->errors < ERR_MAX) {
            s->err_line[s->errors] = s->answered + 1u;
            s->err_code[s->errors] = (unsigned)atoi(l + 6);
        }
        s->errors++;
        s->answered++;
    } else if (strncmp(l, "Grbl ", 5) == 0) {
        s->greetings++;
    } else if (strncmp(l, "ALARM:", 6) == 0) {
        s->alarms++;
        s->alarm_code = (unsigned)atoi(l + 6);
    } else if (l[0] == '<') {
        if (s->poll_waiting) {
            s->poll_waiting = 0;
            if (s->n_lat == s->cap_lat) {
                size_t c = s->cap_lat ? 2 * s->cap_lat : 256;
                double *p = realloc(s->lat_ms, c * sizeof *p);
                if (p == NULL) { /* (a latency figure must not silently leave samples out) */
                    fprintf(stderr, "plotkin avrsim: out of memory for the status latencies\n");
                    exit(1);
                }
                s->lat_ms = p;
                s->cap_lat = c;
            }
            s->lat_ms[s->n_lat++] =
                (double)(pk_avrchip_cycles(&s->chip) - s->poll_sent) * 1000.0 / (double)s->b->f_cpu;
        }
        snprintf(s->status, sizeof s->status, "%s", l);
        s->statuses++;
        s->status_seq++;
    } else if (l[0] == '$' && isdigit((unsigned char)l[1])) {
        if (s->n_set < 64)
            snprintf(s->set_text[s->n_set++], sizeof s->set_text[0], "%s", l);
    } else if (l[0] == '[') {
        if (s->msgs < 8)
            snprintf(s->msg_text[s->msgs], sizeof s->msg_text[0], "%s", l);
        s->msgs++;
    }
}

/* Split what the firmware sent since last time into lines. */
static void scan_output(struct avrsim *s, FILE *echo)
{
    struct pk_avrchip *c = &s->chip;
    for (; s->out_done < c->n_out; s->out_done++) {
        char ch = (char)c->out[s->out_done];
        if (echo != NULL)
            fputc(ch, echo);
        if (ch == '\r')
            continue;
        if (ch == '\n') {
            s->line[s->line_n] = '\0';
            handle_line(s, s->line);
            s->line_n = 0;
        } else if (s->line_n + 1 < sizeof s->line) {
            s->line[s->line_n++] = ch;
        }
    }
}

static int sim_open(struct avrsim *s, const struct pk_avrchip_board *b, const char *hex,
                    const struct pk_timing_limits *lim, FILE *csv)
{
    memset(s, 0, sizeof *s);
    s->b = b;
    s->csv = csv;
    for (int a = 0; a < 3; a++)
        s->spmm[a] = 80.0;
    char err[300];
    if (pk_avrchip_open(&s->chip, b, hex, err, sizeof err) != 0) {
        fprintf(stderr, "plotkin avrsim: %s\n", err);
        return -1;
    }
    struct pk_decode_cfg dc = {
        .tick_hz = b->f_cpu, .axes = b->axes, .enable_invert = b->enable_invert,
        .shared_enable = b->shared_enable, .lim = *lim,
    };
    pk_decoder_init(&s->dec, &dc, &s->res, 0);
    s->dec.on_step = on_step;
    s->dec.on_step_arg = s;
    s->chip.on_edge = on_edge;
    s->chip.on_edge_arg = s;
    if (csv != NULL)
        pk_trace_csv_header(csv, b->f_cpu);
    pk_avrchip_emit_initial(&s->chip);
    return 0;
}

static double secs(const struct avrsim *s, uint64_t cycles) { return (double)cycles / s->b->f_cpu; }

/* Run `cycles` more, then read the output. -1 if the chip stopped. */
static int run_for(struct avrsim *s, uint64_t cycles)
{
    int rc = pk_avrchip_run_until(&s->chip, pk_avrchip_cycles(&s->chip) + cycles);
    scan_output(s, NULL);
    return rc;
}

/* Send bytes, running the chip while its receive FIFO is full. */
static int send_bytes(struct avrsim *s, const char *p, size_t n)
{
    for (size_t i = 0; i < n; i++)
        while (!pk_avrchip_uart_send(&s->chip, (uint8_t)p[i]))
            if (run_for(s, 200) != 0)
                return -1;
    return 0;
}

/* Run until pred holds or `limit_s` emulated seconds pass. 1 held, 0 timeout, -1 chip stopped. */
static int run_until(struct avrsim *s, int (*pred)(const struct avrsim *, const void *),
                     const void *arg, double limit_s)
{
    uint64_t end = pk_avrchip_cycles(&s->chip) + (uint64_t)(limit_s * s->b->f_cpu);
    while (!pred(s, arg)) {
        if (pk_avrchip_cycles(&s->chip) >= end)
            return 0;
        if (run_for(s, 1000) != 0)
            return -1;
    }
    return 1;
}

static int pred_greetings(const struct avrsim *s, const void *arg)
{
    return s->greetings >= *(const unsigned *)arg;
}

static int pred_answered(const struct avrsim *s, const void *arg)
{
    return s->answered >= *(const unsigned *)arg;
}

static int pred_status(const struct avrsim *s, const void *arg)
{
    return s->status_seq > *(const uint64_t *)arg;
}

/* Ask for a status report and wait for it (1), 0 timeout, -1 stopped. */
static int query_status(struct avrsim *s)
{
    uint64_t seq = s->status_seq;
    if (send_bytes(s, "?", 1) != 0)
        return -1;
    return run_until(s, pred_status, &seq, 1.0);
}

static const char *status_state(const struct avrsim *s, char *buf, size_t n)
{
    const char *p = s->status[0] == '<' ? s->status + 1 : s->status;
    size_t k = strcspn(p, "|>");
    if (k >= n)
        k = n - 1;
    memcpy(buf, p, k);
    buf[k] = '\0';
    return buf;
}

/* MPos of the last status report, mm; 0 if none. */
static int status_mpos(const struct avrsim *s, double out[3])
{
    const char *p = strstr(s->status, "MPos:");
    return p != NULL && sscanf(p + 5, "%lf,%lf,%lf", &out[0], &out[1], &out[2]) == 3;
}

/* The last report's position equals the decoded steps (whole steps at the
 * configured steps/mm: MPos is rounded to 1 um, far below one step). */
static int status_matches_pins(const struct avrsim *s)
{
    double mm[3];
    if (!status_mpos(s, mm))
        return 0;
    for (unsigned a = 0; a < s->b->axes; a++)
        if (llround(mm[a] * s->spmm[a]) != s->res.pos[a])
            return 0;
    return 1;
}

/* ---- --run: a character-counting sender -------------------------------------- */

struct prog_line {
    char *text;
    size_t len;
};

static char *slurp(const char *path, size_t *len)
{
    FILE *f = fopen(path, "rb");
    if (f == NULL)
        return NULL;
    size_t cap = 65536, n = 0;
    char *buf = malloc(cap + 1);
    while (buf != NULL) {
        size_t k = fread(buf + n, 1, cap - n, f);
        n += k;
        if (k == 0)
            break;
        if (n == cap) {
            char *nb = realloc(buf, 2 * cap + 1);
            if (nb == NULL) {
                free(buf);
                buf = NULL;
                break;
            }
            buf = nb;
            cap *= 2;
        }
    }
    fclose(f);
    if (buf != NULL) {
        buf[n] = '\0';
        *len = n;
    }
    return buf;
}

/* Non-blank lines, trailing blanks and CR removed (what a sender writes). */
static size_t split_lines(char *text, struct prog_line **out)
{
    size_t n = 0, cap = 256;
    struct prog_line *v = malloc(cap * sizeof *v);
    for (char *p = text; v != NULL && *p;) {
        char *e = strchr(p, '\n');
        char *next = e ? e + 1 : p + strlen(p);
        size_t k = (size_t)((e ? e : next) - p);
        while (k > 0 && (p[k - 1] == '\r' || p[k - 1] == ' ' || p[k - 1] == '\t'))
            k--;
        size_t lead = 0;
        while (lead < k && (p[lead] == ' ' || p[lead] == '\t'))
            lead++;
        if (k > lead) {
            if (n == cap) {
                struct prog_line *nv = realloc(v, 2 * cap * sizeof *v);
                if (nv == NULL) {
                    free(v);
                    return 0;
                }
                v = nv;
                cap *= 2;
            }
            p[k] = '\0';
            v[n++] = (struct prog_line){ p + lead, k - lead };
        }
        p = next;
    }
    *out = v;
    return v ? n : 0;
}

static int parse_at(const char *arg, struct at_event *ev)
{
    const char *colon = strchr(arg, ':');
    if (colon == NULL)
        return -1;
    char *end;
    ev->t_s = strtod(arg, &end);
    if (end != colon || ev->t_s < 0)
        return -1;
    const char *k = colon + 1;
    static const struct { const char *name; uint8_t byte; } kinds[] = {
        { "hold", '!' }, { "resume", '~' }, { "reset", 0x18 }, { "status", '?' },
    };
    for (size_t i = 0; i < sizeof kinds / sizeof kinds[0]; i++)
        if (strcmp(k, kinds[i].name) == 0) {
            ev->byte = kinds[i].byte;
            ev->name = kinds[i].name;
            return 0;
        }
    return -1;
}

struct run_report {
    const char *status;
    unsigned lines_sent, config_errors;
    double t_start_s, t_end_s;
    unsigned hold_checks, hold_exact, hold_still;
    unsigned stopped_reports, stopped_exact;
    char final_state[32];
    int reset_sent;
};

/* Settings first, one at a time (send and wait). Returns -1 if the chip stopped. */
static int send_config(struct avrsim *s, const char *path, struct run_report *r)
{
    size_t len;
    char *text = slurp(path, &len);
    if (text == NULL) {
        fprintf(stderr, "plotkin avrsim: cannot read %s\n", path);
        return -2;
    }
    struct prog_line *ln = NULL;
    size_t n = split_lines(text, &ln);
    int rc = 0;
    for (size_t i = 0; i < n && rc == 0; i++) {
        if (ln[i].text[0] == ';' || ln[i].text[0] == '#')
            continue;
        unsigned num;
        double v;
        if (sscanf(ln[i].text, "$%u=%lf", &num, &v) == 2 && num >= 100 && num <= 102)
            s->spmm[num - 100] = v;
        unsigned want = s->answered + 1u;
        unsigned errs = s->errors;
        if (send_bytes(s, ln[i].text, ln[i].len) != 0 || send_bytes(s, "\n", 1) != 0 ||
            run_until(s, pred_answered, &want, 5.0) != 1)
            rc = -1;
        else if (s->errors != errs) {
            fprintf(stderr, "plotkin avrsim: setting refused: %s (error:%u)\n", ln[i].text,
                    s->err_code[errs < ERR_MAX ? errs : ERR_MAX - 1]);
            r->config_errors++;
        }
    }
    free(ln);
    free(text);
    return rc;
}

/* Stream the program; realtime events at their times; then wait for idle. */
static void run_program(struct avrsim *s, struct prog_line *ln, size_t n, struct at_event *at,
                        unsigned n_at, double timeout_s, struct run_report *r)
{
    const uint64_t f = s->b->f_cpu;
    uint64_t t0 = pk_avrchip_cycles(&s->chip);
    uint64_t deadline = t0 + (uint64_t)(timeout_s * (double)f);
    r->t_start_s = secs(s, t0);
    s->answered = 0;
    s->errors = 0;
    s->oks = 0;
    size_t next = 0;
    unsigned acked_base = 0;
    size_t inflight_bytes = 0, inflight_head = 0;
    unsigned next_at = 0;
    unsigned hold_pending = 0;
    uint64_t hold_steps = 0;
    size_t *lens = calloc(n + 1, sizeof *lens);
    r->status = "finished";
    /* the switches' positions in steps, with the steps/mm of --config */
    pk_sim_inputs_resolve(&s->in, (uint32_t)f, s->spmm);
    s->resolved = 1;
    switches_update(s);
    size_t next_in = 0;
    for (;;) {
        uint64_t now = pk_avrchip_cycles(&s->chip);
        if (now >= deadline) {
            r->status = "timeout";
            break;
        }
        /* scripted input edges (s->in.in[].tick: cycles after the start) */
        for (; next_in < s->in.n; next_in++) {
            const struct pk_sim_input *e = &s->in.in[next_in];
            if (e->is_switch)
                continue;
            if (now < t0 + e->tick)
                break;
            pk_avrchip_input_set(&s->chip, e->input, e->active);
        }
        /* a sender's status polling (--poll-status): the next '?' once the
         * last one is answered (cncjs and UGS wait for the report too) */
        if (s->poll_cycles && !s->poll_waiting && now >= s->poll_next) {
            if (send_bytes(s, "?", 1) != 0)
                goto stopped;
            s->poll_sent = now;
            s->poll_waiting = 1;
            s->poll_next = now + s->poll_cycles;
        }
        /* realtime events */
        while (next_at < n_at && now >= t0 + (uint64_t)(at[next_at].t_s * (double)f)) {
            uint8_t b = at[next_at].byte;
            if (send_bytes(s, (const char *)&b, 1) != 0)
                goto stopped;
            if (b == '!')
                hold_pending = 1;
            if (b == '~' && hold_pending == 2) {
                /* nothing moved between the stop and the resume */
                r->hold_still += s->steps_total == hold_steps;
                hold_pending = 0;
            }
            if (b == 0x18) {
                r->reset_sent = 1;
                unsigned g = s->greetings + 1u;
                if (run_until(s, pred_greetings, &g, 2.0) != 1)
                    goto stopped;
            }
            next_at++;
        }
        if (hold_pending == 1) {
            if (query_status(s) < 0)
                goto stopped;
            char st[32];
            if (strcmp(status_state(s, st, sizeof st), "Hold:0") == 0) {
                r->hold_checks++;
                r->hold_exact += status_matches_pins(s);
                hold_steps = s->steps_total;
                hold_pending = 2;
            }
        }
        /* release the bytes of answered lines, then send while they fit */
        while (acked_base < s->answered && inflight_head < next) {
            inflight_bytes -= lens[inflight_head++];
            acked_base++;
        }
        while (!r->reset_sent && next < n && inflight_bytes + ln[next].len + 1 <= 127) {
            if (send_bytes(s, ln[next].text, ln[next].len) != 0 || send_bytes(s, "\n", 1) != 0)
                goto stopped;
            lens[next] = ln[next].len + 1;
            inflight_bytes += lens[next];
            next++;
        }
        r->lines_sent = (unsigned)next;
        int all_answered = s->answered >= next;
        if ((next == n && all_answered) || r->reset_sent) {
            if (next_at < n_at) { /* events still to come */
                if (run_for(s, 1000) != 0)
                    goto stopped;
                continue;
            }
            /* wait for the machine to stop */
            if (query_status(s) < 0)
                goto stopped;
            char st[32];
            status_state(s, st, sizeof st);
            if (strcmp(st, "Idle") == 0 || strcmp(st, "Alarm") == 0) {
                uint64_t before = s->steps_total;
                if (run_for(s, f / 50u) != 0 || query_status(s) < 0)
                    goto stopped;
                status_state(s, st, sizeof st);
                if ((strcmp(st, "Idle") == 0 || strcmp(st, "Alarm") == 0) && s->steps_total == before) {
                    snprintf(r->final_state, sizeof r->final_state, "%s", st);
                    r->stopped_reports++;
                    r->stopped_exact += status_matches_pins(s);
                    break;
                }
            } else if (run_for(s, f / 50u) != 0) {
                goto stopped;
            }
            continue;
        }
        if (run_for(s, 1000) != 0)
            goto stopped;
    }
    free(lens);
    r->t_end_s = secs(s, pk_avrchip_cycles(&s->chip));
    return;
stopped:
    free(lens);
    r->status = "stopped";
    r->t_end_s = secs(s, pk_avrchip_cycles(&s->chip));
}

/* ---- symbols of the ELF (for --elf) -------------------------------------------- */

struct sym {
    uint32_t addr, size;
    char name[64];
};

static size_t read_syms(const char *elf, struct sym **out)
{
    char cmd[600];
    snprintf(cmd, sizeof cmd, "avr-nm -n -S --defined-only '%s' 2>/dev/null", elf);
    FILE *p = popen(cmd, "r");
    if (p == NULL)
        return 0;
    size_t n = 0, cap = 512;
    struct sym *v = malloc(cap * sizeof *v);
    char line[256];
    while (v != NULL && fgets(line, sizeof line, p)) {
        unsigned long a, sz;
        char type;
        char name[64];
        if (sscanf(line, "%lx %lx %c %63s", &a, &sz, &type, name) != 4 || (type != 't' && type != 'T') ||
            a >= 0x800000ul)
            continue;
        if (n == cap) {
            struct sym *nv = realloc(v, 2 * cap * sizeof *v);
            if (nv == NULL)
                break;
            v = nv;
            cap *= 2;
        }
        v[n].addr = (uint32_t)a;
        v[n].size = (uint32_t)sz;
        snprintf(v[n].name, sizeof v[n].name, "%s", name);
        n++;
    }
    pclose(p);
    *out = v;
    return n;
}

/* Per flash word, 1 inside a library routine (libgcc's arithmetic, avr-libc's
 * mem* / str* / eeprom_*), for --hist-main: those cycles go to the caller.
 * The register save/restore sequences of -mcall-prologues are entered by a
 * jump, as part of the function that uses them: not a library call. */
static uint8_t *lib_words(const struct sym *v, size_t n, size_t words, const char *const *also, unsigned n_also)
{
    uint8_t *m = calloc(words, 1);
    for (size_t i = 0; m != NULL && i < n; i++) {
        const char *nm = v[i].name;
        int lib = 0;
        for (unsigned k = 0; k < n_also; k++)
            lib |= !strcmp(nm, also[k]);
        lib = lib || (!strncmp(nm, "__", 2) && strncmp(nm, "__vector", 8) && strncmp(nm, "__prologue", 10) &&
                   strncmp(nm, "__epilogue", 10) && strncmp(nm, "__bad_interrupt", 15) && strncmp(nm, "__do_", 5) &&
                   strncmp(nm, "__ctors", 7) && strncmp(nm, "__dtors", 7) && strncmp(nm, "__init", 6) &&
                   strncmp(nm, "__trampolines", 13) && strncmp(nm, "__stop", 6)) ||
                  !strncmp(nm, "mem", 3) || !strncmp(nm, "str", 3) || !strncmp(nm, "eeprom_", 7);
        for (uint32_t a = v[i].addr; lib && a < v[i].addr + v[i].size && a / 2u < words; a += 2)
            m[a / 2u] = 1;
    }
    return m;
}

static const struct sym *sym_find(const struct sym *v, size_t n, const char *name)
{
    for (size_t i = 0; i < n; i++)
        if (strcmp(v[i].name, name) == 0)
            return &v[i];
    return NULL;
}

/* ---- reports ---------------------------------------------------------------- */

static const char *vector_name(const struct pk_avrchip_board *b, unsigned v)
{
    if (v == b->step_vector)
        return "step_timer";
    if (strcmp(b->mcu, "atmega328p") == 0)
        return v == 13 ? "step_overflow" : v == 18 ? "uart_rx" : v == 19 ? "uart_tx" : v == 7 || v == 9 ? "servo" : "other";
    return v == 35 ? "step_overflow" : v == 25 ? "uart_rx" : v == 26 ? "uart_tx" : v == 20 ? "servo" : "other";
}

struct peek_req {
    char name[32];
    uint16_t addr;
    unsigned len;
};
static struct peek_req peek[4];
static unsigned n_peek;

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : (x > y ? 1 : 0);
}

/* p50 / p99 / max of the status latencies (nearest rank). */
static void lat_stats(struct avrsim *s, double *p50, double *p99, double *mx)
{
    if (s->n_lat == 0)
        return;
    qsort(s->lat_ms, s->n_lat, sizeof *s->lat_ms, cmp_double);
    *p50 = s->lat_ms[(s->n_lat - 1) / 2];
    *p99 = s->lat_ms[(size_t)((double)(s->n_lat - 1) * 0.99)];
    *mx = s->lat_ms[s->n_lat - 1];
}

static void print_json(FILE *o, struct avrsim *s, const char *hex, const struct run_report *r,
                       const struct sym *syms, size_t nsyms, int profile)
{
    const struct pk_avrchip *c = &s->chip;
    const struct pk_decoded *d = &s->res;
    fprintf(o, "{\n  \"board\": \"%s\",\n  \"mcu\": \"%s\",\n  \"image\": \"%s\",\n", s->b->name,
            s->b->mcu, hex);
    fprintf(o, "  \"status\": \"%s\",\n  \"chip\": \"%s\",\n", r->status, pk_avrchip_state_text(c));
    fprintf(o, "  \"lines\": %u,\n  \"ok\": %u,\n  \"errors\": %u,\n  \"error_lines\": [", r->lines_sent,
            s->oks, s->errors);
    for (unsigned i = 0; i < s->errors && i < ERR_MAX; i++)
        fprintf(o, "%s[%u, %u]", i ? ", " : "", s->err_line[i], s->err_code[i]);
    fprintf(o, "],\n  \"config_errors\": %u,\n  \"alarms\": %u,\n  \"alarm\": %u,\n", r->config_errors,
            s->alarms, s->alarm_code);
    fprintf(o, "  \"steps\": [%" PRIu64 ", %" PRIu64 ", %" PRIu64 "],\n", d->steps[0], d->steps[1], d->steps[2]);
    fprintf(o, "  \"final_steps\": [%" PRId64 ", %" PRId64 ", %" PRId64 "],\n", d->pos[0], d->pos[1], d->pos[2]);
    double mm[3] = { 0, 0, 0 };
    status_mpos(s, mm);
    fprintf(o, "  \"status_report\": \"%s\",\n  \"firmware_mm\": [%.3f, %.3f, %.3f],\n", s->status,
            mm[0], mm[1], mm[2]);
    fprintf(o, "  \"final_state\": \"%s\",\n  \"stopped_reports\": %u,\n  \"stopped_exact\": %u,\n",
            r->final_state, r->stopped_reports, r->stopped_exact);
    fprintf(o, "  \"hold_checks\": %u,\n  \"hold_exact\": %u,\n  \"hold_still\": %u,\n", r->hold_checks,
            r->hold_exact, r->hold_still);
    fprintf(o, "  \"greetings\": %u,\n", s->greetings);
    if (s->poll_cycles) {
        double p50 = 0, p99 = 0, mx = 0;
        lat_stats(s, &p50, &p99, &mx);
        fprintf(o, "  \"status_polls\": %zu,\n  \"status_latency_ms\": { \"p50\": %.3f, \"p99\": %.3f, \"max\": %.3f },\n",
                s->n_lat, p50, p99, mx);
    }
    fprintf(o, "  \"messages\": [");
    for (unsigned i = 0; i < s->msgs && i < 8; i++) {
        fputs(i ? ", \"" : "\"", o);
        for (const char *q = s->msg_text[i]; *q; q++)
            if (*q == '"' || *q == '\\')
                fprintf(o, "\\%c", *q);
            else if ((unsigned char)*q >= 0x20)
                fputc(*q, o);
        fputc('"', o);
    }
    fprintf(o, "],\n");
    fprintf(o, "  \"settings\": {");
    for (unsigned i = 0; i < s->n_set; i++) {
        const char *eq = strchr(s->set_text[i], '=');
        if (eq != NULL)
            fprintf(o, "%s\"%.*s\": \"%s\"", i ? ", " : "", (int)(eq - s->set_text[i] - 1),
                    s->set_text[i] + 1, eq + 1);
    }
    fprintf(o, "},\n");
    fprintf(o, "  \"timing_violations\": %zu,\n  \"violations\": [", d->n_viol);
    for (size_t i = 0; i < d->n_viol && i < 10; i++)
        fprintf(o, "%s{\"t_s\": %.6f, \"kind\": \"%s\", \"axis\": %u, \"got_ns\": %" PRIu64 ", \"limit_ns\": %u}",
                i ? ", " : "", secs(s, d->viol[i].t), pk_violation_name(d->viol[i].kind), d->viol[i].axis,
                d->viol[i].got_ns, d->viol[i].limit_ns);
    fprintf(o, "],\n  \"steps_while_disabled\": %" PRIu64 ",\n", d->steps_while_disabled);
    fprintf(o, "  \"program_s\": %.6f,\n", r->t_end_s - r->t_start_s);
    fprintf(o, "  \"motion_s\": %.6f,\n", s->steps_total ? secs(s, s->last_step - s->first_step) : 0.0);
    fprintf(o, "  \"first_step_s\": %.6f,\n", s->steps_total ? secs(s, s->first_step) - r->t_start_s : 0.0);
    fprintf(o, "  \"pen_changes\": %u,\n", s->pen_changes);
    double us = s->b->f_cpu / 1e6;
    fprintf(o, "  \"servo\": {\"pulses\": %u, \"period_ms\": [%.3f, %.3f], \"width_us\": [%.1f, %.1f], \"widths_us\": [",
            c->servo_pulses, c->servo_period_min / us / 1000.0, c->servo_period_max / us / 1000.0,
            c->servo_width_min / us, c->servo_width_max / us);
    for (unsigned i = 0; i < c->n_servo_widths; i++)
        fprintf(o, "%s%.1f", i ? ", " : "", c->servo_widths[i] / us);
    fprintf(o, "]},\n");
    fprintf(o, "  \"cycles\": %" PRIu64 ",\n  \"timer_starts\": %" PRIu64 ",\n", pk_avrchip_cycles(c),
            c->timer_starts);
    fprintf(o, "  \"stack_bytes\": %u,\n  \"ram_bytes\": %u,\n", pk_avrchip_stack_bytes(c),
            pk_avrchip_ram_bytes(c));
    fprintf(o, "  \"isr_response_cycles\": %u,\n  \"isr\": {", pk_avrchip_isr_response(c));
    int first = 1;
    for (unsigned v = 0; v < PK_AVRCHIP_VECTORS; v++) {
        if (!c->isr[v].calls)
            continue;
        fprintf(o, "%s\"%u\": {\"name\": \"%s\", \"calls\": %" PRIu64 ", \"cycles\": %" PRIu64
                   ", \"max\": %" PRIu64 ", \"max_incl\": %" PRIu64 "}", first ? "" : ", ", v,
                vector_name(s->b, v), c->isr[v].calls, c->isr[v].cycles, c->isr[v].max, c->isr[v].max_incl);
        first = 0;
    }
    fprintf(o, "},\n  \"functions\": {");
    for (unsigned i = 0; i < c->n_fn; i++)
        fprintf(o, "%s\"%s\": {\"calls\": %" PRIu64 ", \"cycles\": %" PRIu64 ", \"max\": %" PRIu64
                   ", \"max_at_s\": %.6f}",
                i ? ", " : "", c->fn[i].name, c->fn[i].calls, c->fn[i].cycles, c->fn[i].max,
                secs(s, c->fn[i].max_t0));
    fprintf(o, "},\n  \"watches\": {");
    for (unsigned i = 0; i < c->n_watch; i++)
        fprintf(o, "%s\"%s\": %" PRIu64, i ? ", " : "", c->watch[i].name, c->watch[i].changes);
    fprintf(o, "},\n  \"peeks\": {");
    for (unsigned i = 0; i < n_peek; i++) {
        uint8_t b[8] = { 0 };
        uint64_t v = 0;
        if (pk_avrchip_peek(c, peek[i].addr, b, peek[i].len) == 0)
            for (unsigned k = peek[i].len; k-- > 0;)
                v = v << 8 | b[k];
        fprintf(o, "%s\"%s\": %" PRIu64, i ? ", " : "", peek[i].name, v);
    }
    fprintf(o, "}");
    if (profile && c->hist != NULL) {
        /* flat profile of the step interrupt: cycles per function */
        fprintf(o, ",\n  \"step_isr_profile\": {");
        uint64_t other = 0;
        int k = 0;
        uint64_t *per = calloc(nsyms + 1, sizeof *per);
        for (size_t w = 0; per != NULL && w < c->hist_words; w++) {
            if (!c->hist[w])
                continue;
            size_t j;
            for (j = 0; j < nsyms; j++)
                if (2u * w >= syms[j].addr && 2u * w < syms[j].addr + syms[j].size)
                    break;
            if (j < nsyms)
                per[j] += c->hist[w];
            else
                other += c->hist[w];
        }
        for (size_t j = 0; per != NULL && j < nsyms; j++)
            if (per[j])
                fprintf(o, "%s\"%s\": %" PRIu64, k++ ? ", " : "", syms[j].name, per[j]);
        if (other)
            fprintf(o, "%s\"(vector table/no symbol)\": %" PRIu64, k ? ", " : "", other);
        free(per);
        fprintf(o, "}");
    }
    fprintf(o, "\n}\n");
}

static void print_text(FILE *o, struct avrsim *s, const struct run_report *r)
{
    const struct pk_decoded *d = &s->res;
    double mm[3] = { 0, 0, 0 };
    status_mpos(s, mm);
    fprintf(o, "plotkin avrsim: %s (%s) %s after %.3f s emulated (%s)\n", s->b->name, s->b->mcu,
            r->status, r->t_end_s, pk_avrchip_state_text(&s->chip));
    fprintf(o, "  lines %u: ok %u, errors %u, alarms %u; final state %s\n", r->lines_sent, s->oks,
            s->errors, s->alarms, r->final_state[0] ? r->final_state : "?");
    fprintf(o, "  steps X %" PRIu64 " Y %" PRIu64 " Z %" PRIu64 "; final position (steps) %" PRId64
               " %" PRId64 " %" PRId64 "; firmware reports %.3f %.3f %.3f mm\n",
            d->steps[0], d->steps[1], d->steps[2], d->pos[0], d->pos[1], d->pos[2], mm[0], mm[1], mm[2]);
    fprintf(o, "  timing violations %zu; pen changes %u; motion %.3f s; stack %u B; timer starts %" PRIu64 "\n",
            d->n_viol, s->pen_changes, s->steps_total ? secs(s, s->last_step - s->first_step) : 0.0,
            pk_avrchip_stack_bytes(&s->chip), s->chip.timer_starts);
    if (s->poll_cycles) {
        double p50 = 0, p99 = 0, mx = 0;
        lat_stats(s, &p50, &p99, &mx);
        fprintf(o, "  status polled at %.0f Hz: %zu reports, latency ('?' sent to the report's end) p50 %.2f ms, p99 %.2f ms, max %.2f ms\n",
                (double)s->b->f_cpu / (double)s->poll_cycles, s->n_lat, p50, p99, mx);
    }
}

/* ---- --link: a pseudo-terminal ------------------------------------------------- */

static volatile sig_atomic_t stop_req;
static void on_signal(int sig)
{
    (void)sig;
    stop_req = 1;
}

static double wall_s(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + ts.tv_nsec / 1e9;
}

static int link_mode(struct avrsim *s, const char *link, double speed)
{
    struct pk_serial ser;
    int rc = pk_serial_open_pty(&ser, link);
    if (rc != 0) {
        fprintf(stderr, "plotkin avrsim: cannot make a pty at %s: %s\n", link, strerror(-rc));
        return 1;
    }
    printf("plotkin avrsim: %s (%s) on %s (link %s)\n", s->b->name, s->b->mcu, ser.path, link);
    fflush(stdout);
    signal(SIGINT, on_signal);
    signal(SIGTERM, on_signal);
    uint8_t in[256];
    size_t in_n = 0, in_i = 0;
    const uint64_t slice = s->b->f_cpu / 1000u; /* 1 ms */
    double w0 = wall_s();
    uint64_t c0 = pk_avrchip_cycles(&s->chip);
    int status = 0;
    while (!stop_req) {
        if (pk_avrchip_run_until(&s->chip, pk_avrchip_cycles(&s->chip) + slice) != 0) {
            fprintf(stderr, "plotkin avrsim: the chip %s\n", pk_avrchip_state_text(&s->chip));
            status = 1;
            break;
        }
        /* chip -> pty */
        struct pk_avrchip *c = &s->chip;
        while (s->out_done < c->n_out) {
            ssize_t w = write(ser.fd, c->out + s->out_done, c->n_out - s->out_done);
            if (w <= 0)
                break;
            size_t old = s->out_done;
            for (size_t i = old; i < old + (size_t)w; i++) {
                char ch = (char)c->out[i];
                if (ch == '\n') {
                    s->line[s->line_n] = '\0';
                    handle_line(s, s->line);
                    s->line_n = 0;
                } else if (ch != '\r' && s->line_n + 1 < sizeof s->line) {
                    s->line[s->line_n++] = ch;
                }
            }
            s->out_done = old + (size_t)w;
        }
        if (s->out_done == c->n_out) {
            c->n_out = 0;
            s->out_done = 0;
        }
        /* pty -> chip */
        if (in_i == in_n) {
            ssize_t r = read(ser.fd, in, sizeof in);
            in_i = 0;
            in_n = r > 0 ? (size_t)r : 0;
        }
        while (in_i < in_n && pk_avrchip_uart_send(&s->chip, in[in_i]))
            in_i++;
        if (speed > 0) {
            double ahead = secs(s, pk_avrchip_cycles(&s->chip) - c0) / speed - (wall_s() - w0);
            if (ahead > 0.002) {
                struct timespec ts = { 0, (long)(ahead * 1e9) };
                nanosleep(&ts, NULL);
            }
        }
    }
    pk_serial_close(&ser);
    struct run_report r = { .status = status ? "stopped" : "finished" };
    r.t_end_s = secs(s, pk_avrchip_cycles(&s->chip));
    print_text(stdout, s, &r);
    return status;
}

/* ---- the command -------------------------------------------------------------- */

int cmd_avrsim(int argc, char **argv)
{
    const char *hex = NULL, *board = "uno-cnc-shield", *run = NULL, *config = NULL, *trace = NULL;
    const char *link = NULL, *driver = "drv8825", *elf = NULL, *hist_out = NULL;
    int hist_main = 0;
    uint8_t *hist_lib = NULL;
    const char *charge[12];
    unsigned n_charge = 0;
    int json = 0, profile = 0;
    double timeout = 600.0, speed = 1.0, poll_hz = 0.0;
    struct at_event at[AT_MAX];
    unsigned n_at = 0;
    static struct pk_sim_inputs inputs;
    const char *eeprom = NULL;
    static uint8_t ee[4096];
    static char watch_name[4][32];
    int watch_addr[4];
    unsigned n_watch = 0;
    const char *xfn[12];
    unsigned n_xfn = 0;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        const char *v = i + 1 < argc ? argv[i + 1] : NULL;
        if (!strcmp(a, "--help") || !strcmp(a, "-h")) {
            fputs(avrsim_usage, stdout);
            return 0;
        } else if (!strcmp(a, "--json")) {
            json = 1;
        } else if (!strcmp(a, "--profile")) {
            profile = 1;
        } else if (v != NULL && !strcmp(a, "--hist")) {
            hist_out = v, i++, profile = 1;
        } else if (v != NULL && !strcmp(a, "--hist-main")) {
            hist_out = v, i++, profile = 1, hist_main = 1;
        } else if (v != NULL && !strcmp(a, "--charge-caller")) {
            if (n_charge == 12) {
                fprintf(stderr, "plotkin avrsim: at most 12 --charge-caller\n");
                return 2;
            }
            charge[n_charge++] = v, i++;
        } else if (v != NULL && !strcmp(a, "--fn")) {
            if (n_xfn == 12) {
                fprintf(stderr, "plotkin avrsim: at most 12 --fn\n");
                return 2;
            }
            xfn[n_xfn++] = v, i++;
        } else if (v != NULL && !strcmp(a, "--board")) {
            board = v, i++;
        } else if (v != NULL && !strcmp(a, "--run")) {
            run = v, i++;
        } else if (v != NULL && !strcmp(a, "--config")) {
            config = v, i++;
        } else if (v != NULL && !strcmp(a, "--trace")) {
            trace = v, i++;
        } else if (v != NULL && !strcmp(a, "--link")) {
            link = v, i++;
        } else if (v != NULL && !strcmp(a, "--driver")) {
            driver = v, i++;
        } else if (v != NULL && !strcmp(a, "--elf")) {
            elf = v, i++;
        } else if (v != NULL && !strcmp(a, "--timeout")) {
            timeout = atof(v), i++;
        } else if (v != NULL && !strcmp(a, "--poll-status")) {
            char *end;
            poll_hz = strtod(v, &end), i++;
            if (*end != '\0' || !(poll_hz > 0.0 && poll_hz <= 1000.0)) {
                fprintf(stderr, "plotkin avrsim: --poll-status wants a rate in Hz (0 < HZ <= 1000)\n");
                return 2;
            }
        } else if (v != NULL && !strcmp(a, "--speed")) {
            speed = atof(v), i++;
        } else if (v != NULL && !strcmp(a, "--watch")) {
            if (n_watch == 4 || sscanf(v, "%31[^:]:%i", watch_name[n_watch], &watch_addr[n_watch]) != 2) {
                fprintf(stderr, "plotkin avrsim: bad --watch '%s' (NAME:ADDRESS, at most 4)\n", v);
                return 2;
            }
            n_watch++, i++;
        } else if (v != NULL && !strcmp(a, "--peek")) {
            int ad, ln;
            if (n_peek == 4 || sscanf(v, "%31[^:]:%i:%i", peek[n_peek].name, &ad, &ln) != 3 || ln < 1 ||
                ln > 8 || ad < 0 || ad > 0xFFFF) {
                fprintf(stderr, "plotkin avrsim: bad --peek '%s' (NAME:ADDRESS:BYTES, 1..8 bytes, at most 4)\n", v);
                return 2;
            }
            peek[n_peek].addr = (uint16_t)ad;
            peek[n_peek].len = (unsigned)ln;
            n_peek++, i++;
        } else if (v != NULL && (!strcmp(a, "--input") || !strcmp(a, "--switch"))) {
            char ierr[160];
            if (pk_sim_inputs_add(&inputs, a, v, ierr, sizeof ierr) != 0) {
                fprintf(stderr, "plotkin avrsim: %s\n", ierr);
                return 2;
            }
            i++;
        } else if (v != NULL && !strcmp(a, "--eeprom")) {
            eeprom = v, i++;
        } else if (v != NULL && !strcmp(a, "--at")) {
            if (n_at == AT_MAX || parse_at(v, &at[n_at]) != 0) {
                fprintf(stderr, "plotkin avrsim: bad --at '%s' (SECONDS:hold|resume|reset|status, at most %d)\n",
                        v, AT_MAX);
                return 2;
            }
            n_at++, i++;
        } else if (a[0] != '-' && hex == NULL) {
            hex = a;
        } else {
            fprintf(stderr, "plotkin avrsim: unknown or incomplete option '%s'\n%s", a, avrsim_usage);
            return 2;
        }
    }
    if (!pk_avrchip_available()) {
        fprintf(stderr, "plotkin avrsim: %s\n", pk_avrchip_missing_text());
        return 2;
    }
    if (hex == NULL || (run == NULL) == (link == NULL)) {
        fprintf(stderr, "plotkin avrsim: give FIRMWARE.hex and one of --run or --link\n%s", avrsim_usage);
        return 2;
    }
    for (unsigned i = 1; i < n_at; i++)
        if (at[i].t_s < at[i - 1].t_s) {
            fprintf(stderr, "plotkin avrsim: --at events must be given in time order\n");
            return 2;
        }
    const struct pk_avrchip_board *b = pk_avrchip_board_find(board);
    if (b == NULL) {
        fprintf(stderr, "plotkin avrsim: unknown board '%s' (", board);
        for (const struct pk_avrchip_board *p = pk_avrchip_boards; p->name; p++)
            fprintf(stderr, "%s%s", p == pk_avrchip_boards ? "" : ", ", p->name);
        fprintf(stderr, ")\n");
        return 2;
    }
    struct pk_timing_limits lim = PK_TIMING_DRV8825;
    if (!strcmp(driver, "a4988"))
        lim = (struct pk_timing_limits){ 1000u, 1000u, 200u, 200u };
    else if (!strcmp(driver, "tmc2209"))
        lim = (struct pk_timing_limits){ 100u, 100u, 20u, 20u };
    else if (strcmp(driver, "drv8825") != 0) {
        fprintf(stderr, "plotkin avrsim: unknown driver '%s' (drv8825, a4988, tmc2209)\n", driver);
        return 2;
    }
    FILE *csv = NULL;
    if (trace != NULL && (csv = fopen(trace, "w")) == NULL) {
        fprintf(stderr, "plotkin avrsim: cannot write %s: %s\n", trace, strerror(errno));
        return 2;
    }
    static struct avrsim s;
    for (size_t k = 0; k < inputs.n; k++)
        if (b->input[inputs.in[k].input].port == 0) {
            fprintf(stderr, "plotkin avrsim: board %s has no input line for --input/--switch %zu\n",
                    b->name, k + 1);
            return 2;
        }
    if (sim_open(&s, b, hex, &lim, csv) != 0) {
        if (csv)
            fclose(csv);
        return 1;
    }
    s.in = inputs;
    if (poll_hz > 0.0)
        s.poll_cycles = (uint64_t)((double)b->f_cpu / poll_hz);
    long ee_size = pk_avrchip_eeprom(&s.chip, NULL, 0, 0);
    if (eeprom != NULL) {
        FILE *ef = fopen(eeprom, "rb");
        if (ee_size <= 0 || ee_size > (long)sizeof ee) {
            fprintf(stderr, "plotkin avrsim: --eeprom: the part's EEPROM is not readable\n");
            pk_avrchip_close(&s.chip);
            return 2;
        }
        if (ef != NULL) {
            size_t got = fread(ee, 1, (size_t)ee_size, ef);
            fclose(ef);
            if (got != (size_t)ee_size || pk_avrchip_eeprom(&s.chip, ee, got, 1) < 0) {
                fprintf(stderr, "plotkin avrsim: %s: want %ld bytes of EEPROM, read %zu\n", eeprom, ee_size, got);
                pk_avrchip_close(&s.chip);
                return 2;
            }
        }
    }
    for (unsigned i = 0; i < n_watch; i++)
        if (pk_avrchip_watch(&s.chip, watch_name[i], (uint16_t)watch_addr[i]) != 0) {
            fprintf(stderr, "plotkin avrsim: --watch %s: address 0x%x outside the data memory\n",
                    watch_name[i], watch_addr[i]);
            pk_avrchip_close(&s.chip);
            return 2;
        }
    struct sym *syms = NULL;
    size_t nsyms = 0;
    if (elf != NULL) {
        nsyms = read_syms(elf, &syms);
        static const char *const fns[] = { "pk_grbl_poll", "pk_machine_poll", "pk_gcode_parse",
                                           "pk_gcode_interp", "pk_refine_pull", "pk_stroke_pull",
                                           "pk_sg_prep", "pk_planner_add_line", "pk_planner_replan",
                                           "pk_machine_timer_cb", "pk_sg_isr" };
        for (size_t i = 0; i < sizeof fns / sizeof fns[0]; i++) {
            const struct sym *y = sym_find(syms, nsyms, fns[i]);
            if (y != NULL)
                pk_avrchip_track_fn(&s.chip, fns[i], y->addr);
        }
        for (unsigned i = 0; i < n_xfn; i++) {
            const struct sym *y = sym_find(syms, nsyms, xfn[i]);
            size_t ln = strlen(xfn[i]);
            for (size_t k = 0; y == NULL && k < nsyms; k++)
                if (!strncmp(syms[k].name, xfn[i], ln) && syms[k].name[ln] == '.')
                    y = &syms[k];
            if (y == NULL) {
                fprintf(stderr, "plotkin avrsim: --fn %s: no such function in %s\n", xfn[i], elf);
                continue;
            }
            pk_avrchip_track_fn(&s.chip, xfn[i], y->addr);
        }
        if (profile) {
            s.chip.hist_words = 131072;
            s.chip.hist = calloc(s.chip.hist_words, sizeof *s.chip.hist);
            s.chip.hist_main = hist_main;
            if (hist_main)
                s.chip.hist_lib = hist_lib = lib_words(syms, nsyms, s.chip.hist_words, charge, n_charge);
        }
    }
    int rc;
    if (link != NULL) {
        rc = link_mode(&s, link, speed);
    } else {
        struct run_report r = { .status = "finished" };
        size_t len;
        char *text = slurp(run, &len);
        struct prog_line *ln = NULL;
        size_t n = text ? split_lines(text, &ln) : 0;
        unsigned one = 1;
        if (text == NULL) {
            fprintf(stderr, "plotkin avrsim: cannot read %s\n", run);
            rc = 2;
        } else if (run_until(&s, pred_greetings, &one, 2.0) != 1) {
            r.status = "no greeting";
            print_json(stdout, &s, hex, &r, syms, nsyms, 0);
            rc = 1;
        } else if (config != NULL && (rc = send_config(&s, config, &r)) != 0) {
            r.status = rc == -2 ? "bad config file" : "stopped";
            rc = rc == -2 ? 2 : 1;
        } else {
            run_program(&s, ln, n, at, n_at, timeout, &r);
            if (json)
                print_json(stdout, &s, hex, &r, syms, nsyms, profile);
            else
                print_text(stdout, &s, &r);
            rc = strcmp(r.status, "finished") != 0 || s.errors || r.config_errors || s.res.n_viol ||
                         (s.alarms && !r.reset_sent)
                     ? 1
                     : 0;
        }
        free(ln);
        free(text);
    }
    if (hist_out != NULL && s.chip.hist != NULL) {
        FILE *hf = fopen(hist_out, "w");
        for (size_t w = 0; hf != NULL && w < s.chip.hist_words; w++)
            if (s.chip.hist[w])
                fprintf(hf, "0x%zx %" PRIu64 "\n", 2u * w, s.chip.hist[w]);
        if (hf == NULL || fclose(hf) != 0)
            fprintf(stderr, "plotkin avrsim: cannot write %s\n", hist_out);
    }
    if (eeprom != NULL) {
        FILE *ef = fopen(eeprom, "wb");
        if (ef == NULL || pk_avrchip_eeprom(&s.chip, ee, (size_t)ee_size, 0) < 0 ||
            fwrite(ee, 1, (size_t)ee_size, ef) != (size_t)ee_size) {
            fprintf(stderr, "plotkin avrsim: cannot write the EEPROM to %s\n", eeprom);
            rc = rc ? rc : 1;
        }
        if (ef != NULL && fclose(ef) != 0)
            rc = rc ? rc : 1;
    }
    if (csv)
        fclose(csv);
    free(syms);
    free(s.chip.hist);
    free(hist_lib);
    free(s.lat_ms);
    pk_decoded_free(&s.res);
    pk_avrchip_close(&s.chip);
    return rc;
}
