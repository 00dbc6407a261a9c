/*
 * cmd_serve.c — `plotkin serve`: run the firmware (Grbl protocol engine +
 * motion core) in the simulator in real time and expose it on a
 * pseudo-terminal, so any G-code sender can connect as if to a board.
 *
 *   plotkin serve [--link PATH] [--speed N] [--device PATH --baud N] [--eeprom FILE]
 *                 [--input T:NAME=V] [--switch NAME:AXIS:MM[:-]]
 *
 * The simulated clock follows the wall clock times N (--speed). Each loop
 * iteration moves bytes between the pty and the UART shim (the "RX/TX
 * interrupts"), then runs main-loop iterations of the firmware every 0.5 ms
 * of simulated time, with the step-timer callbacks at their exact simulated
 * ticks in between (host-sim/grbl_sim.c), until the simulated clock has
 * caught up with the wall clock; then it sleeps in poll() until input arrives
 * or the next millisecond. If the host cannot keep up (very high --speed), the
 * simulation runs as fast as it can and the lag is reported, never
 * accumulated.
 *
 * The serial side (a pty that survives client disconnects, with a stable
 * --link, or a real device; output nobody read is dropped only after a whole
 * second without any client; when the last client closes, what it sent is
 * still read and executed up to its last complete line and its unfinished
 * line is dropped with pk_grbl_drop_partial_line, so a half "G0 X1" is never
 * glued to the next client's "0 Y5") is hal/posix/pk_serve_port.h, shared
 * with the Linux board's `plotkin-gpiod serve`.
 * --eeprom FILE keeps the settings, offsets and startup lines in FILE (the
 * board's EEPROM: hal/posix/pk_nvm_file.h) across runs; without it they
 * start from the defaults every time.
 * --input / --switch give the machine input lines as in `plotkin sim`
 * (sim_inputs.h; a switch's mm are turned into steps with the default
 * steps/mm, an edge's seconds count from the start of the session); the Grbl
 * settings act on them ($21=1 hard limits, $H, G38.x, Pn:).
 * SIGINT/SIGTERM stop it cleanly and a summary is printed.
 *
 * The machine is `plotkin sim`'s (host-sim/serve_sim.h): the libgpiod backend
 * on the mock GPIO chip, the simulator's scheduler and clock, and the pin
 * trace decoded on the fly with the driver's timing checks, so memory stays
 * flat over an endless session and the summary printed on exit is `plotkin
 * sim`'s (host-sim/sim_report.h): timing violations, max speed and
 * acceleration, final position decoded from the step pins, ...
 */
#define _XOPEN_SOURCE 700
#include <errno.h>
#include <poll.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include "commands.h"
#include "serve_sim.h"
#include "sim_inputs.h"
#include "sim_report.h"
#include "posix/pk_nvm_file.h"
#include "posix/pk_serve_port.h"

#define TICK_HZ 1000000u

/* The one piece of process state a signal handler may touch. */
static volatile sig_atomic_t serve_stop;

static void on_signal(int sig)
{
    (void)sig;
    serve_stop = 1;
}

static uint64_t now_ns(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (uint64_t)ts.tv_sec * 1000000000ull + (uint64_t)ts.tv_nsec;
}

static void usage(FILE *f)
{
    fputs("usage: plotkin serve [--link PATH] [--speed N] [--device PATH [--baud N]] [--eeprom FILE]\n"
          "\n"
          "Run the simulated machine in real time and speak Grbl 1.1 on a pseudo-terminal.\n"
          "  --link PATH    also make PATH a symlink to the pty (stable name for senders)\n"
          "  --speed N      simulated clock runs N times faster than the wall clock (1..100000)\n"
          "  --device PATH  serve on a real serial device instead of a pty (raw mode)\n"
          "  --baud N       baud rate for --device (default 115200)\n"
          "  --eeprom FILE  keep settings, offsets and startup lines in FILE across runs\n"
          "  --input T:NAME=V, --switch NAME:AXIS:MM[:-]  input lines, as in plotkin sim\n"
          "                 (then $21=1 hard limits, $H, G38.x and Pn: act on them)\n"
          "Stops on SIGINT/SIGTERM and prints a summary.\n",
          f);
}

static const char *state_name(int st)
{
    switch (st) {
    case PK_STATE_RUN: return "Run";
    case PK_STATE_HOLDING: return "Hold:1";
    case PK_STATE_HOLD: return "Hold:0";
    case PK_STATE_ALARM: return "Alarm";
    default: return "Idle";
    }
}

int cmd_serve(int argc, char **argv)
{
    static struct pk_sim_inputs inputs;
    const char *link = NULL, *device = NULL, *eeprom = NULL;
    long speed = 1, baud = 115200;
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--help") || !strcmp(argv[i], "-h")) {
            usage(stdout);
            return 0;
        } else if (!strcmp(argv[i], "--link") && i + 1 < argc) {
            link = argv[++i];
        } else if (!strcmp(argv[i], "--device") && i + 1 < argc) {
            device = argv[++i];
        } else if (!strcmp(argv[i], "--eeprom") && i + 1 < argc) {
            eeprom = argv[++i];
        } else if ((!strcmp(argv[i], "--input") || !strcmp(argv[i], "--switch")) && i + 1 < argc) {
            char ierr[160];
            if (pk_sim_inputs_add(&inputs, argv[i], argv[i + 1], ierr, sizeof ierr) != 0) {
                fprintf(stderr, "plotkin serve: %s\n", ierr);
                return 2;
            }
            i++;
        } else if ((!strcmp(argv[i], "--speed") || !strcmp(argv[i], "--baud")) && i + 1 < argc) {
            char *end;
            long v = strtol(argv[i + 1], &end, 10);
            if (*end != '\0' || v < 1 || (argv[i][2] == 's' && v > 100000)) {
                fprintf(stderr, "plotkin serve: bad value for %s: '%s'\n", argv[i], argv[i + 1]);
                return 2;
            }
            if (argv[i][2] == 's')
                speed = v;
            else
                baud = v;
            i++;
        } else {
            fprintf(stderr, "plotkin serve: unknown option '%s'\n", argv[i]);
            usage(stderr);
            return 2;
        }
    }

    static struct pk_nvm_file nvf = { -1, 0 };
    struct pk_grbl_nvm nvm, *nvmp = NULL;
    if (eeprom != NULL) {
        int e = pk_nvm_file_open(&nvf, eeprom, pk_grbl_nvm_bytes());
        if (e != 0) {
            fprintf(stderr, "plotkin serve: --eeprom %s: %s\n", eeprom, strerror(-e));
            return 1;
        }
        nvm = (struct pk_grbl_nvm){ pk_nvm_file_read, pk_nvm_file_write, &nvf, nvf.size };
        nvmp = &nvm;
    }
    struct pk_serve_sim *sim = calloc(1, sizeof *sim);
    const struct pk_timing_limits lim = PK_TIMING_DRV8825;
    struct pk_sim_cfg dcfg;
    pk_sim_cfg_default(&dcfg);
    pk_sim_inputs_resolve(&inputs, dcfg.tick_hz, dcfg.steps_per_mm);
    if (sim == NULL ||
        pk_serve_sim_start_in(sim, "plotkin-serve0", &lim, nvmp, inputs.in, inputs.n) != 0) {
        fprintf(stderr, "plotkin serve: cannot initialise the machine%s%s\n", sim ? ": " : "",
                sim ? sim->r.err : "");
        if (sim)
            pk_serve_sim_free(sim);
        free(sim);
        return 1;
    }
    struct pk_serve_port port;
    int rc = pk_serve_port_open(&port, device, (uint32_t)baud, link, stderr);
    if (rc != 0) {
        fprintf(stderr, "plotkin serve: %s: %s\n", device ? device : "pty", strerror(-rc));
        pk_serve_sim_free(sim);
        free(sim);
        return 1;
    }
    struct pk_serial *ser = &port.ser;
    pk_serve_port_signals(on_signal);

    if (device)
        printf("plotkin serve: Grbl 1.1 on %s at %ld baud\n", ser->path, baud);
    else if (link)
        printf("plotkin serve: Grbl 1.1 on %s (link %s), speed x%ld\n", ser->path, link, speed);
    else
        printf("plotkin serve: Grbl 1.1 on %s, speed x%ld\n", ser->path, speed);
    fflush(stdout);

    uint64_t t0 = now_ns(), wall_start = t0;
    uint64_t sim_base = 0, lag_events = 0;
    int io_error = 0, sim_error = 0;
    while (!serve_stop) {
        rc = pk_serve_port_pump(&port, &sim->uart);
        if (rc < 0) {
            io_error = 1;
            break;
        }
        if (rc & PK_SERVE_PORT_LEFT)
            pk_grbl_drop_partial_line(&sim->g); /* before a byte of the next client */
        if (rc & PK_SERVE_PORT_RX)
            pk_serve_sim_wake(sim); /* the receive interrupt wakes the main loop */
        uint64_t now = pk_serve_sim_now(sim);
        uint64_t target = sim_base + (now_ns() - t0) / 1000u * (uint64_t)speed * (TICK_HZ / 1000000u);
        /* At most ~1 ms of wall-equivalent work between two pumps. */
        uint64_t slice_end = now + (uint64_t)speed * (TICK_HZ / 1000u);
        if (slice_end > target)
            slice_end = target;
        if (slice_end > now && pk_serve_sim_run(sim, slice_end - now) != 0) {
            sim_error = 1;
            break;
        }
        pk_grbl_poll(&sim->g);
        if (pk_serial_pump(ser, &sim->uart) != 0) {
            io_error = 1;
            break;
        }
        uint64_t now_target =
            sim_base + (now_ns() - t0) / 1000u * (uint64_t)speed * (TICK_HZ / 1000000u);
        if (now_target > pk_serve_sim_now(sim) + (uint64_t)TICK_HZ / 2u * (uint64_t)speed) {
            /* More than half a wall second behind: run as fast as we can
             * from here instead of trying to catch up. */
            lag_events++;
            sim_base = pk_serve_sim_now(sim);
            t0 = now_ns();
            continue;
        }
        if (pk_serve_sim_now(sim) >= now_target) {
            struct pollfd p = { ser->fd, POLLIN, 0 };
            poll(&p, 1, 1);
        }
    }
    double wall = (double)(now_ns() - wall_start) / 1e9;
    pk_um_t pos[PK_AXES];
    pk_machine_position_um(&sim->r.m, pos);
    const struct pk_grbl_stats *st = &sim->g.stats;
    printf("plotkin serve: stopped%s%s\n", io_error ? " (I/O error on the serial line)" : "",
           sim_error ? " (the simulation broke down, see run below)" : "");
    printf("  wall time %.3f s, speed x%ld%s\n", wall, speed,
           lag_events ? " (host could not keep up)" : "");
    printf("  lines %u: %u ok, %u error; moves %u; soft resets %u\n", st->lines, st->ok,
           st->errors, st->moves, st->resets);
    printf("  serial: %llu bytes in, %llu bytes out, %u bytes lost to overflow, "
           "%llu client connections\n",
           (unsigned long long)ser->rx_bytes, (unsigned long long)ser->tx_bytes,
           (unsigned)pk_uart_rx_dropped(&sim->uart), (unsigned long long)port.connections);
    printf("  state %s, position X%.3f Y%.3f Z%.3f mm\n", state_name(pk_machine_state(&sim->r.m)),
           pos[0] / 1000.0, pos[1] / 1000.0, PK_AXES > 2 ? pos[PK_AXES - 1] / 1000.0 : 0.0);
    /* The simulated machine's own report, as `plotkin sim` prints it. */
    if (pk_serve_sim_finish(sim) == 0) {
        printf("plotkin serve: the simulated machine, as `plotkin sim` reports it\n");
        pk_sim_print_summary(stdout, &sim->r, sim->cfg.axes, &sim->cfg, "drv8825");
    } else {
        printf("  (no machine summary: %s)\n", sim->r.err);
    }
    fflush(stdout);
    pk_serve_port_close(&port);
    pk_serve_sim_free(sim);
    free(sim);
    pk_nvm_file_close(&nvf);
    return io_error || sim_error ? 1 : 0;
}
