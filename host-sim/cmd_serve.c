/*
 * cmd_serve.c — `plotkin serve`: run the firmware (Grbl protocol engine +
 * motion core) in the simulator in real time and expose it on a
 * pseudo-terminal, so any G-code sender can connect as if to a board.
 *
 *   plotkin serve [--link PATH] [--speed N] [--device PATH --baud N] [--eeprom FILE]
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
 * The pty survives client disconnects (we hold our own slave fd open), so a
 * sender can disconnect and reconnect. serve counts the clients that have the
 * pty open (inotify IN_OPEN / IN_CLOSE on the slave's inode; our own slave fd
 * was opened before the watch) and drops output only once nobody has had the
 * pty open for a whole second: a sender that reconnects at once still gets
 * the answers to what it sent, a client connecting later does not start with
 * stale lines, and a client that is merely slow never loses a byte (a lost
 * `ok` would hang a character-counting sender). The events are read at the
 * top of every loop iteration, before the line is read, and a client's open
 * is queued before anything it writes, so its first answer is never dropped.
 * When the last client closes the pty, whatever it sent is still read and
 * executed up to its last complete line, and its unfinished line is dropped
 * (pk_grbl_drop_partial_line) before a byte of the next client is read: a
 * half "G0 X1" is never glued to the next client's "0 Y5". (Grbl boards get
 * the same from the reset a port open gives them.)
 * --eeprom FILE keeps the settings, offsets and startup lines in FILE (the
 * board's EEPROM: hal/posix/pk_nvm_file.h) across runs; without it they
 * start from the defaults every time.
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
#include <sys/inotify.h>
#include <unistd.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include "commands.h"
#include "serve_sim.h"
#include "sim_report.h"
#include "posix/pk_nvm_file.h"
#include "posix/pk_serial.h"

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
    if (sim == NULL || pk_serve_sim_start_nvm(sim, "plotkin-serve0", &lim, nvmp) != 0) {
        fprintf(stderr, "plotkin serve: cannot initialise the machine%s%s\n", sim ? ": " : "",
                sim ? sim->r.err : "");
        if (sim)
            pk_serve_sim_free(sim);
        free(sim);
        return 1;
    }
    struct pk_serial ser;
    int rc = device ? pk_serial_open(&ser, device, (uint32_t)baud) : pk_serial_open_pty(&ser, link);
    if (rc != 0) {
        fprintf(stderr, "plotkin serve: %s: %s\n", device ? device : "pty", strerror(-rc));
        pk_serve_sim_free(sim);
        free(sim);
        return 1;
    }
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_signal;
    sigemptyset(&sa.sa_mask);
    sigaction(SIGINT, &sa, NULL);
    sigaction(SIGTERM, &sa, NULL);
    signal(SIGPIPE, SIG_IGN);

    if (device)
        printf("plotkin serve: Grbl 1.1 on %s at %ld baud\n", ser.path, baud);
    else if (link)
        printf("plotkin serve: Grbl 1.1 on %s (link %s), speed x%ld\n", ser.path, link, speed);
    else
        printf("plotkin serve: Grbl 1.1 on %s, speed x%ld\n", ser.path, speed);
    fflush(stdout);

    uint64_t t0 = now_ns(), wall_start = t0;
    uint64_t sim_base = 0, lag_events = 0;
    /* A client opening the slave is what makes unread output stale. */
    int opens = device ? -1 : inotify_init1(IN_NONBLOCK | IN_CLOEXEC);
    unsigned long clients = 0, connections = 0;
    uint64_t alone_since = 0; /* wall ns since the pty has had no client; 0: has one */
    if (opens >= 0 && inotify_add_watch(opens, ser.path, IN_OPEN | IN_CLOSE) < 0) {
        close(opens);
        opens = -1;
    }
    if (!device && opens < 0)
        fprintf(stderr, "plotkin serve: inotify unavailable (%s): a reconnecting client may "
                        "see answers meant for the previous one\n", strerror(errno));
    int io_error = 0, sim_error = 0, draining = 0;
    while (!serve_stop) {
        if (opens >= 0) {
            char evbuf[16 * (sizeof(struct inotify_event) + 16)]
                __attribute__((aligned(__alignof__(struct inotify_event))));
            ssize_t n;
            while ((n = read(opens, evbuf, sizeof evbuf)) > 0) {
                for (char *q = evbuf; q < evbuf + n;) {
                    const struct inotify_event *e = (const struct inotify_event *)(void *)q;
                    if (e->mask & IN_OPEN) {
                        if (clients++ == 0)
                            connections++;
                    }
                    if ((e->mask & IN_CLOSE) && clients > 0 && --clients == 0) {
                        /* the last client left: read what it sent before it
                         * closed, then drop its unfinished line */
                        ser.rx_allow = (long)pk_serial_pending(&ser);
                        draining = 1;
                    }
                    q += sizeof *e + e->len;
                }
            }
            if (clients > 0)
                alone_since = 0;
            else if (alone_since == 0)
                alone_since = now_ns();
            else if (now_ns() - alone_since >= 1000000000ull)
                pk_serial_discard_unread(&ser); /* nobody has been there for 1 s */
        }
        if (draining && ser.rx_allow == 0 && pk_uart_rx_used(&sim->uart) == 0) {
            pk_grbl_drop_partial_line(&sim->g);
            ser.rx_allow = -1;
            draining = 0;
        }
        uint64_t rx0 = ser.rx_bytes;
        if (pk_serial_pump(&ser, &sim->uart) != 0) {
            io_error = 1;
            break;
        }
        if (ser.rx_bytes != rx0)
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
        if (pk_serial_pump(&ser, &sim->uart) != 0) {
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
            struct pollfd p = { ser.fd, POLLIN, 0 };
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
           (unsigned long long)ser.rx_bytes, (unsigned long long)ser.tx_bytes,
           (unsigned)pk_uart_rx_dropped(&sim->uart), (unsigned long long)connections);
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
    if (opens >= 0)
        close(opens);
    pk_serial_close(&ser);
    pk_serve_sim_free(sim);
    free(sim);
    pk_nvm_file_close(&nvf);
    return io_error || sim_error ? 1 : 0;
}
