/*
 * avr_chip.h — a whole AVR board emulated by libsimavr, for running the very
 * image `make firmware` builds (its Intel HEX) on an emulated ATmega328P or
 * ATmega2560 at 16 MHz, cycle-exactly (host only).
 *
 * The harness owns one simulated chip: it loads the HEX, feeds the USART
 * (a byte is offered only while simavr's receive FIFO has room), collects
 * what the firmware transmits, and turns every change of the board's step,
 * direction and enable pins into a pk_trace_edge stamped with the cycle
 * counter (so tick_hz = the CPU clock), exactly as the host simulator's
 * mock GPIO chip does, for the same decoder and driver-timing checks
 * (sim_trace.h). The pen servo pin's pulses are measured (width, period) and
 * reported as pen edges: pen down while the pulse is wider than the middle of
 * the board's servo range.
 *
 * Measurements made while it runs (the image is not instrumented; the chip
 * is stepped one instruction at a time and its state read between steps):
 *   - the deepest stack: the lowest stack pointer ever seen, interrupts
 *     included, so RAM = data + bss + (RAMEND - lowest SP);
 *   - every interrupt: calls, cycles (first vector instruction through reti,
 *     plus the hardware's 4-cycle response, 5 on 3-byte-PC parts), longest;
 *     an interrupt that runs nested inside another (the step interrupt lets
 *     the serial line in) is counted for itself only: `cycles` and `max` are
 *     exclusive, `max_incl` includes what nested inside;
 *   - the step timer's compare interrupt enable bit set outside the step
 *     interrupt: a timer start (pk_machine_poll arming the timer), so a run
 *     that should be one continuous motion shows underruns as extra starts;
 *   - optionally the cycles of each flash word executed inside the step
 *     interrupt (a flat profile), and the inclusive cycles of up to
 *     PK_AVRCHIP_MAX_FN functions outside interrupts.
 *
 * Where simavr is not installed (no libsimavr headers at build time) the
 * module still compiles: pk_avrchip_available() returns 0 and open fails
 * with a message saying how to get it.
 *
 * Host-only code (heap, stdio, doubles are fine here). One struct per chip;
 * several chips may coexist.
 */
#ifndef PLOTKIN_AVR_CHIP_H
#define PLOTKIN_AVR_CHIP_H

#include <stddef.h>
#include <stdint.h>
#include "sim_trace.h"

#define PK_AVRCHIP_MAX_AXES 3
#define PK_AVRCHIP_MAX_FN 24
#define PK_AVRCHIP_VECTORS 64

/** Input lines of a board, indexed as enum pk_hal_input (hal.h). */
#define PK_AVRCHIP_INPUTS 9

/** One pin: port letter and bit. port 0 = not wired. */
struct pk_avrchip_pin {
    char port;
    uint8_t bit;
};

/**
 * A board as the host sees it: the same map as hal/avr/<board>/board.h (which
 * the image uses; the whole-chip tests fail if the two disagree).
 */
struct pk_avrchip_board {
    const char *name;                 /**< "uno-cnc-shield", as hal/avr/<name>/ */
    const char *mcu;                  /**< simavr part name */
    uint32_t f_cpu;                   /**< Hz */
    uint16_t ram_start;               /**< data address of the first RAM byte */
    unsigned axes;                    /**< step/dir pairs wired */
    struct pk_avrchip_pin step[PK_AVRCHIP_MAX_AXES], dir[PK_AVRCHIP_MAX_AXES];
    struct pk_avrchip_pin enable[PK_AVRCHIP_MAX_AXES]; /**< shared: only [0] */
    int shared_enable;
    uint32_t enable_invert;           /**< axis bits whose enable is active low */
    struct pk_avrchip_pin servo;      /**< pen servo output */
    uint32_t servo_min_us, servo_max_us; /**< pulse of value 0 (pen up) and full scale */
    uint8_t step_vector;              /**< vector number of the step timer's compare ISR */
    uint16_t step_timsk;              /**< data address of its interrupt mask register */
    uint8_t step_ocie;                /**< its compare interrupt enable bit */
    /** Input pins (limit switches, probe, ...: enum pk_hal_input order), as
     *  board.h wires them for PK_BOARD_INPUTS; all on pull-ups. */
    struct pk_avrchip_pin input[PK_AVRCHIP_INPUTS];
    uint32_t input_invert;            /**< input bits whose line is active low */
    /** A pin-change group simavr does not model (simavr 1.6's ATmega2560 has
     *  pin change on port B only): the harness raises its interrupt itself,
     *  as the datasheet describes, when a pin of `port` it drives changes
     *  while the group is enabled (pcicr & pcie) and the pin is in the mask
     *  (pcmsk bit pin + shift). port 0: none. Data addresses. */
    struct pk_avrchip_pcx {
        char port;
        uint8_t shift, vector, pcie, pcif;
        uint16_t pcicr, pcmsk, pcifr;
    } pcx;
};

/** The boards known to the harness (NULL-terminated by name == NULL). */
extern const struct pk_avrchip_board pk_avrchip_boards[];
/** Board by name, or NULL. */
const struct pk_avrchip_board *pk_avrchip_board_find(const char *name);

/** Per-vector interrupt statistics, cycles. */
struct pk_avrchip_isr {
    uint64_t calls, cycles, max, max_incl;
};

/** Inclusive cycles of one function, wherever it runs (main loop or an
 *  interrupt), less the interrupts that nested inside its calls. */
struct pk_avrchip_fn {
    const char *name;
    uint32_t addr;                    /**< byte address of its first instruction */
    uint64_t calls, cycles, max;
    uint64_t max_t0;                  /**< the cycle the longest call began at */
    /* private: the call in progress */
    int active;
    uint8_t level;                    /**< interrupt nesting level it runs at */
    uint16_t sp;                      /**< SP at its first instruction */
    uint32_t ret;                     /**< byte address it returns to (from the stack) */
    uint64_t t0, isr0;
};

/** A RAM byte whose changes are counted (e.g. a ring's head index). */
struct pk_avrchip_watch {
    const char *name;
    uint16_t addr;
    uint8_t last;
    uint64_t changes;
};
#define PK_AVRCHIP_MAX_WATCH 4

struct pk_avrchip {
    const struct pk_avrchip_board *b;
    void *avr;                        /**< avr_t * (opaque here) */
    /* serial: what the firmware sent */
    uint8_t *out;
    size_t n_out, cap_out;
    int rx_full;                      /**< simavr's receive FIFO is full (XOFF) */
    uint64_t bytes_in, bytes_out;
    /* pins */
    pk_trace_edge_fn on_edge;         /**< every decoded pin edge (tick = cycle) */
    void *on_edge_arg;
    uint64_t edges;
    /* servo */
    uint64_t servo_rise, servo_prev_rise;
    uint32_t servo_pulses;
    uint64_t servo_period_min, servo_period_max; /**< cycles between rising edges */
    uint64_t servo_width_min, servo_width_max;   /**< cycles high */
    uint64_t servo_width_last;
    uint64_t servo_widths[16];        /**< the first 16 widths seen, each change of more
                                           than 4 us recorded once (cycles) */
    unsigned n_servo_widths;
    int pen;                          /**< logical pen level decoded (-1 unknown) */
    /* measurements */
    uint16_t sp_min;                  /**< lowest SP seen */
    struct pk_avrchip_isr isr[PK_AVRCHIP_VECTORS];
    uint64_t isr_cycles_total;        /**< all interrupt cycles */
    uint64_t timer_starts;            /**< step-timer compare interrupt enabled 0 -> 1 */
    struct pk_avrchip_fn fn[PK_AVRCHIP_MAX_FN];
    unsigned n_fn;
    struct pk_avrchip_watch watch[PK_AVRCHIP_MAX_WATCH];
    unsigned n_watch;
    uint64_t *hist;                   /**< if not NULL: cycles per flash word inside the step ISR
                                           (hist_main: outside every interrupt instead) */
    int hist_main;
    size_t hist_words;
    const uint8_t *hist_lib;          /**< with hist_main, if not NULL: per flash word, 1 = a library
                                           routine (libgcc, libc): its cycles are charged to the call
                                           instruction in the image's own code that entered it */
    uint32_t hist_site[64];           /**< (private) return addresses of the calls under way */
    uint8_t hist_depth;
    /* private */
    struct pk_avrchip_tap { struct pk_avrchip *c; uint8_t kind, axis; } taps[3 * PK_AVRCHIP_MAX_AXES + 1];
    uint8_t level[3 * PK_AVRCHIP_MAX_AXES + 1];
    struct pk_avrchip_frame { uint8_t vec; uint64_t t0, nested; } frames[8];
    uint8_t n_frames;
    uint64_t nest_acc[9];             /**< cycles of interrupts entered directly at each level */
    uint8_t timsk_last;
    int state;                        /**< simavr cpu state after the last step */
    /* inputs: the logical levels asked for, and those on the pins */
    uint32_t in_want, in_have;
    int in_dirty;
    void *pcx_vec;                    /**< avr_int_vector_t of b->pcx (opaque here) */
    uint64_t input_edges;             /**< input pin changes applied */
};

/** 1 if this build has libsimavr, else 0. */
int pk_avrchip_available(void);
/** The message to print when it is not. */
const char *pk_avrchip_missing_text(void);

/**
 * Make the chip of board b and load the Intel HEX at hex_path into its flash.
 * Returns 0, or -1 with the reason in err (no simavr, unreadable HEX, image
 * larger than the part's flash, unknown part). Free with pk_avrchip_close.
 */
int pk_avrchip_open(struct pk_avrchip *c, const struct pk_avrchip_board *b, const char *hex_path,
                    char *err, size_t errlen);
void pk_avrchip_close(struct pk_avrchip *c);

/** Cycles run so far. */
uint64_t pk_avrchip_cycles(const struct pk_avrchip *c);

/**
 * Run until the cycle counter reaches `until` (or the firmware stops or
 * crashes). Returns 0 while the chip runs, -1 once it has stopped (crash,
 * sleep with interrupts off): see pk_avrchip_state_text.
 */
int pk_avrchip_run_until(struct pk_avrchip *c, uint64_t until);
const char *pk_avrchip_state_text(const struct pk_avrchip *c);

/** Offer one byte to the USART receiver. Returns 1 if taken, 0 if its FIFO
 *  is full right now (run a little, then retry). */
int pk_avrchip_uart_send(struct pk_avrchip *c, uint8_t byte);

/** Emit the initial level of every wired pin as an initial edge (call once
 *  the sink is set, before running). */
void pk_avrchip_emit_initial(struct pk_avrchip *c);

/**
 * Set input `input` (enum pk_hal_input) to logical level `active` (1 =
 * switch closed / probe touching), as the board's wiring and polarity say.
 * The pin changes at the next instruction boundary outside every interrupt
 * handler (a real switch may change at any time; moving the edge by at most
 * one handler's length keeps the harness simple and changes nothing a
 * switch's bounce would not). Inputs the board does not wire are ignored.
 */
void pk_avrchip_input_set(struct pk_avrchip *c, unsigned input, int active);

/**
 * The chip's EEPROM: copy it out into buf (set = 0) or load buf into it
 * (set = 1), n bytes from address 0. Returns the part's EEPROM size, or -1
 * (n larger than the EEPROM, no simavr).
 */
long pk_avrchip_eeprom(struct pk_avrchip *c, uint8_t *buf, size_t n, int set);

/** RAM the image's stack reached: RAMEND - lowest SP (bytes). */
unsigned pk_avrchip_stack_bytes(const struct pk_avrchip *c);
/** Data RAM of the part (bytes, registers and I/O excluded). */
unsigned pk_avrchip_ram_bytes(const struct pk_avrchip *c);

/** Track the inclusive cycles of a function at byte address addr (from the
 *  image's ELF). Returns 0, or -1 if the table is full. */
int pk_avrchip_track_fn(struct pk_avrchip *c, const char *name, uint32_t addr);

/** Count the changes of the RAM byte at data address addr. 0, or -1 if full. */
int pk_avrchip_watch(struct pk_avrchip *c, const char *name, uint16_t addr);

/** Copy n bytes of data memory at addr (0, or -1 out of range). */
int pk_avrchip_peek(const struct pk_avrchip *c, uint16_t addr, void *out, size_t n);

/** Cycles of the hardware's interrupt response added to every ISR. */
unsigned pk_avrchip_isr_response(const struct pk_avrchip *c);

#endif
