/*
 * plotkin_gpiod.c — the firmware on a Linux board: `plotkin-gpiod`.
 *
 * Runs a G-code (or polyline) file through the same firmware and the same
 * job code as `plotkin sim`, but on real GPIO lines through libgpiod
 * (hal/gpiod/, linked with -lgpiod) and on real time (hal/posix/). Built by
 * `make board-gpiod`; this file is outside the wildcard source lists so the
 * simulator never links it, and the board never links the libgpiod mock.
 *
 *   plotkin-gpiod --board BOARD.conf [--config MACHINE.conf] [--realtime] FILE
 *
 * BOARD.conf is the wiring (see hal/gpiod/pk_gpiod.h, e.g.
 * hal/gpiod/rpi-plotter.conf); MACHINE.conf the `$N=value` settings.
 * SIGINT/SIGTERM stop the motion at once (like Grbl's reset) and release the
 * lines.
 */
#include <errno.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "gpiod/pk_gpiod.h"
#include "posix/pk_posix_timer.h"
#include "sim_job.h"

static volatile int stop_requested; /* set by the signal handler only */

static void on_signal(int sig)
{
    (void)sig;
    stop_requested = 1;
}

/* The loop's edge source: the input lines' events (limit switches, probe).
 * A failing event read leaves the inputs unwatched: stop the run. */
static int edges_failed;
static void edge_poll(void *arg)
{
    struct pk_gpiod *g = arg;
    if (!edges_failed && pk_gpiod_input_service(g) < 0) {
        fprintf(stderr, "plotkin-gpiod: %s\n", pk_gpiod_error_text(g));
        edges_failed = 1;
        stop_requested = 1;
    }
}

static char *slurp(const char *path)
{
    FILE *f = fopen(path, "rb");
    if (f == NULL)
        return NULL;
    size_t cap = 4096, n = 0;
    char *b = malloc(cap + 1);
    for (;;) {
        if (b == NULL)
            break;
        n += fread(b + n, 1, cap - n, f);
        if (n < cap)
            break;
        char *nb = realloc(b, cap * 2 + 1);
        if (nb == NULL) {
            free(b);
            b = NULL;
            break;
        }
        b = nb;
        cap *= 2;
    }
    fclose(f);
    if (b != NULL)
        b[n] = '\0';
    return b;
}

int main(int argc, char **argv)
{
    const char *board = NULL, *config = NULL, *file = NULL;
    int realtime = 0;
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--board") && i + 1 < argc)
            board = argv[++i];
        else if (!strcmp(argv[i], "--config") && i + 1 < argc)
            config = argv[++i];
        else if (!strcmp(argv[i], "--realtime"))
            realtime = 1;
        else if (argv[i][0] != '-' && file == NULL)
            file = argv[i];
        else {
            fprintf(stderr, "usage: plotkin-gpiod --board BOARD.conf [--config MACHINE.conf] [--realtime] FILE\n");
            return 2;
        }
    }
    if (board == NULL || file == NULL) {
        fprintf(stderr, "usage: plotkin-gpiod --board BOARD.conf [--config MACHINE.conf] [--realtime] FILE\n");
        return 2;
    }
    char err[200];
    static struct pk_gpiod_cfg bcfg;
    static struct pk_sim_cfg mcfg;
    pk_gpiod_cfg_init(&bcfg);
    pk_sim_cfg_default(&mcfg);
    char *text = slurp(board);
    if (text == NULL || pk_gpiod_cfg_parse(&bcfg, text, err, sizeof err) != PK_HAL_OK) {
        fprintf(stderr, "plotkin-gpiod: %s: %s\n", board, text ? err : strerror(errno));
        free(text);
        return 2;
    }
    free(text);
    if (config != NULL) {
        text = slurp(config);
        if (text == NULL || pk_sim_cfg_parse(&mcfg, text, err, sizeof err, stderr) != 0) {
            fprintf(stderr, "plotkin-gpiod: %s: %s\n", config, text ? err : strerror(errno));
            free(text);
            return 2;
        }
        free(text);
    }
    /* The machine drives the axes the board wires (a plotter: X Y + pen). */
    mcfg.axes = bcfg.axes < PK_AXES ? bcfg.axes : PK_AXES;
    if (mcfg.axes < 2u) {
        fprintf(stderr, "plotkin-gpiod: the board wires %u axis; plotkin needs 2 or more\n",
                (unsigned)bcfg.axes);
        return 2;
    }
    static struct pk_motion_cfg motion;
    if (pk_sim_cfg_motion(&mcfg, &motion, err, sizeof err) != 0) {
        fprintf(stderr, "plotkin-gpiod: %s\n", err);
        return 2;
    }
    char *prog = slurp(file);
    if (prog == NULL) {
        fprintf(stderr, "plotkin-gpiod: %s: %s\n", file, strerror(errno));
        return 2;
    }
    int is_poly = 0;
    char *g = pk_sim_polyline_to_gcode(prog, mcfg.polyline_feed, &is_poly);
    if (g != NULL) {
        free(prog);
        prog = g;
    }

    static struct pk_posix_timer timer;
    static struct pk_gpiod gpio;
    static struct pk_machine m;
    static struct pk_sim_job job;
    struct pk_hal base, hal;
    pk_posix_timer_init(&timer, mcfg.tick_hz);
    pk_posix_timer_hal(&timer, &base);
    if (pk_gpiod_open(&gpio, &bcfg, &base, &hal) != PK_HAL_OK) {
        fprintf(stderr, "plotkin-gpiod: %s\n", pk_gpiod_error_text(&gpio));
        pk_gpiod_close(&gpio);
        free(prog);
        return 1;
    }
    int status = 0;
    timer.irq_poll = edge_poll;
    timer.irq_arg = &gpio;
    if (pk_machine_init(&m, &motion, &hal) != PK_MOTION_OK) {
        fprintf(stderr, "plotkin-gpiod: machine init failed: %s\n", pk_hal_error_text(&hal));
        status = 1;
    } else {
        if (realtime && pk_posix_realtime() != 0)
            fprintf(stderr, "plotkin-gpiod: note: no real-time scheduling (needs root)\n");
        signal(SIGINT, on_signal);
        signal(SIGTERM, on_signal);
        pk_sim_job_init(&job, &m, &mcfg, prog, strlen(prog));
        int stopped = pk_posix_run(&timer, pk_sim_job_main, &job, &stop_requested);
        if (stopped)
            (void)pk_machine_reset(&m);
        pk_steps_t pos[PK_AXES];
        pk_machine_position_steps(&m, pos);
        printf("plotkin-gpiod: %s: %lu lines, %lu errors, %lu alarms%s%s; position",
               stopped ? "stopped" : "done", job.lines, job.errors, job.alarms,
               job.alarms ? ": " : "", job.alarm_text);
        for (unsigned a = 0; a < mcfg.axes; a++)
            printf(" %ld", (long)pos[a]);
        printf(" steps; latest timer callback %llu ticks late\n", (unsigned long long)timer.late_max);
        status = stopped || job.alarms || job.errors ? 1 : 0;
        pk_sim_job_free(&job);
    }
    pk_gpiod_close(&gpio);
    free(prog);
    return status;
}
