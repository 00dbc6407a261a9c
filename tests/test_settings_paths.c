/*
 * test_settings_paths.c — one `$N` settings table for both ways a user
 * configures plotkin: `$N=value` lines sent to the Grbl engine (firmware,
 * pk_grbl.c, over the UART shim into a simulated machine) and the same lines
 * in a `plotkin sim --config` file (host-sim/sim_job.c's loader). Both must
 * give the motion core the same configuration, reject the same lines with
 * the same Grbl error, and a `$$` dump from the engine must load as is.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "th.h"
#define GRBL_FIXTURE_OUT_SIZE (1 << 16)
#include "grbl_sim_fixture.h"
#include "sim_job.h"

int th_main(int argc, char **argv);

/* Send one line to the engine and run until it is answered; returns the
 * answer ("ok" or "error:N"), or "" if none came within 2 s simulated. */
static const char *engine_line(const char *line)
{
    static char ans[32];
    size_t before = outn;
    for (const char *p = line; *p; p++)
        pk_uart_rx_push(&S.uart, (uint8_t)*p);
    pk_uart_rx_push(&S.uart, '\n');
    for (int i = 0; i < 4000; i++) {
        pk_grbl_sim_step(&S, 500);
        drain();
        const char *a = out + before;
        const char *ok = strstr(a, "ok\r\n"), *er = strstr(a, "error:");
        if (er != NULL && strchr(er, '\n') != NULL) {
            snprintf(ans, sizeof ans, "%.*s", (int)strcspn(er, "\r\n"), er);
            return ans;
        }
        if (ok != NULL)
            return "ok";
    }
    return "";
}

static void engine_start(void)
{
    pk_grbl_sim_free(&S);
    TH_ASSERT_EQ(pk_grbl_sim_init(&S, 1000000, NULL), 0);
    outn = 0;
    out[0] = 0;
    for (int i = 0; i < 10; i++) {
        pk_grbl_sim_step(&S, 500);
        drain();
    }
}

static void expect_same_motion_cfg(const struct pk_motion_cfg *a, const struct pk_motion_cfg *b)
{
    TH_ASSERT_EQ(a->axes, b->axes);
    for (int i = 0; i < PK_AXES; i++) {
        TH_ASSERT_EQ(a->steps_per_mm_q16[i], b->steps_per_mm_q16[i]);
        TH_ASSERT_EQ(a->max_rate[i], b->max_rate[i]);
        TH_ASSERT_EQ(a->accel[i], b->accel[i]);
    }
    TH_ASSERT_EQ(a->junction_dev_um, b->junction_dev_um);
    TH_ASSERT_EQ(a->step_pulse_ticks, b->step_pulse_ticks);
    TH_ASSERT_EQ(a->dir_setup_ticks, b->dir_setup_ticks);
    TH_ASSERT_EQ(a->pen_settle_ms, b->pen_settle_ms);
    TH_ASSERT_EQ(a->pen_down_level, b->pen_down_level);
    TH_ASSERT_EQ(a->smooth.mode, b->smooth.mode);
    TH_ASSERT_EQ(a->smooth.scheme, b->smooth.scheme);
    TH_ASSERT_EQ(a->smooth.degree, b->smooth.degree);
    TH_ASSERT_EQ(a->smooth.depth, b->smooth.depth);
    TH_ASSERT_EQ(a->smooth.tolerance_um, b->smooth.tolerance_um);
    TH_ASSERT_EQ(a->smooth.sharp_turn_deg, b->smooth.sharp_turn_deg);
}

/* Every plotkin setting changed from its default, fractional values where
 * the setting takes them. */
static const char *const changed[] = {
    "$0=4",       "$11=0.015", "$12=0.05",  "$100=53.3", "$101=40",  "$102=400.125",
    "$110=4500",  "$111=3000.5", "$112=800", "$120=750",  "$121=420", "$122=90",
    "$130=210.5", "$131=297",  "$132=12",   "$201=0",    "$202=2",   "$203=4",
    "$204=45",    "$205=120",  "$206=3",    "$200=1",
};

static void test_the_same_settings_lines_configure_the_same_machine_on_both_paths(void)
{
    engine_start();
    char file[1024] = "";
    for (size_t i = 0; i < TH_COUNT(changed); i++) {
        TH_ASSERT_EQ(strcmp(engine_line(changed[i]), "ok"), 0);
        strcat(file, changed[i]);
        strcat(file, "\n");
    }
    struct pk_sim_cfg c;
    char err[200] = "";
    pk_sim_cfg_default(&c);
    TH_ASSERT_EQ(pk_sim_cfg_parse(&c, file, err, sizeof err, NULL), 0);
    struct pk_motion_cfg mc;
    TH_ASSERT_EQ(pk_sim_cfg_motion(&c, &mc, err, sizeof err), 0);
    expect_same_motion_cfg(&S.m.cfg, &mc);

    /* Independent spot checks from the numbers written above. */
    TH_ASSERT_EQ(mc.steps_per_mm_q16[0], (pk_spmm_q16_t)llround(53.3 * 65536.0));
    TH_ASSERT_EQ(mc.steps_per_mm_q16[2], (pk_spmm_q16_t)llround(400.125 * 65536.0));
    TH_ASSERT_EQ(mc.max_rate[1], 3000500u);          /* µm/min */
    TH_ASSERT_EQ(mc.accel[2], 90000u);                /* µm/s^2 */
    TH_ASSERT_EQ(mc.junction_dev_um, 15);
    TH_ASSERT_EQ(mc.step_pulse_ticks, 4u);            /* 4 µs at 1 MHz */
    TH_ASSERT_EQ(mc.dir_setup_ticks, 3u);
    TH_ASSERT_EQ(mc.pen_settle_ms, 120u);
    TH_ASSERT_EQ(mc.smooth.mode, PK_SMOOTH_FIXED);
    TH_ASSERT_EQ(mc.smooth.depth, 4);
    TH_ASSERT_EQ(mc.smooth.sharp_turn_deg, 45);

    /* The job's engine (plotkin sim) holds the very settings the engine given
     * the lines holds (plotkin serve). */
    static struct pk_sim_job j;
    pk_sim_job_init(&j, &S.m, &c, "", 0);
    for (int i = 0; i < PK_GRBL_S_COUNT; i++)
        TH_EXPECT_EQ(j.g.set.v[i], S.g.set.v[i]);
    TH_ASSERT_EQ(pk_grbl_setting_scaled(&j.g.set, PK_GRBL_S_TRAVEL_X, 3), 210500);
    pk_sim_job_free(&j);
}

static void test_defaults_are_the_same_on_both_paths(void)
{
    engine_start();
    struct pk_sim_cfg c;
    struct pk_motion_cfg mc;
    char err[200];
    pk_sim_cfg_default(&c);
    TH_ASSERT_EQ(pk_sim_cfg_motion(&c, &mc, err, sizeof err), 0);
    expect_same_motion_cfg(&S.m.cfg, &mc);
}

static void test_a_settings_dump_from_the_engine_loads_as_a_config_file(void)
{
    engine_start();
    TH_ASSERT_EQ(strcmp(engine_line("$101=12.5"), "ok"), 0);
    TH_ASSERT_EQ(strcmp(engine_line("$205=7"), "ok"), 0);
    TH_ASSERT_EQ(strcmp(engine_line("$12=0.125"), "ok"), 0);
    size_t before = outn;
    TH_ASSERT_EQ(strcmp(engine_line("$$"), "ok"), 0);
    const char *dump = out + before;
    TH_EXPECT(count(dump, "\r\n$") + (dump[0] == '$') == PK_GRBL_S_COUNT);
    char text[2048];
    snprintf(text, sizeof text, "%s", dump);
    char *okp = strstr(text, "ok\r\n");
    TH_ASSERT(okp != NULL);
    *okp = '\0';
    struct pk_sim_cfg c;
    struct pk_motion_cfg mc;
    char err[200] = "";
    pk_sim_cfg_default(&c);
    TH_ASSERT_EQ(pk_sim_cfg_parse(&c, text, err, sizeof err, NULL), 0);
    TH_ASSERT_EQ(pk_sim_cfg_motion(&c, &mc, err, sizeof err), 0);
    expect_same_motion_cfg(&S.m.cfg, &mc);
    TH_ASSERT_EQ(mc.steps_per_mm_q16[1], 12.5 * 65536);
}

/* Lines the engine refuses: the loader refuses each, naming the same Grbl
 * error, and leaves the configuration as it was. */
static void test_both_paths_refuse_the_same_lines_with_the_same_error(void)
{
    static const char *const bad[] = {
        "$100=0", "$0=0.5", "$202=8", "$11=-1", "$100=abc", "$12=0.0004",
        "$130=2001", "$200=3", "$205=60001", "$100=",
    };
    for (size_t i = 0; i < TH_COUNT(bad); i++) {
        engine_start();
        const char *a = engine_line(bad[i]);
        TH_ASSERT(strncmp(a, "error:", 6) == 0);
        struct pk_sim_cfg c, c0;
        char err[200] = "";
        pk_sim_cfg_default(&c);
        c0 = c;
        TH_ASSERT_EQ(pk_sim_cfg_parse(&c, bad[i], err, sizeof err, NULL), -1);
        char want[40];
        snprintf(want, sizeof want, ": %s ", a);
        if (strstr(err, want) == NULL) {
            th_print(bad[i]); th_print("\n");
            th_print(a); th_print("\n");
            th_print(err); th_print("\n");
        }
        TH_EXPECT(strstr(err, want) != NULL);
        TH_EXPECT(memcmp(&c, &c0, sizeof c) == 0);
    }
    pk_grbl_sim_free(&S);
}

int th_main(int argc, char **argv)
{
    (void)argc;
    (void)argv;
    static const struct th_case cases[] = {
        TH_CASE(test_defaults_are_the_same_on_both_paths),
        TH_CASE(test_the_same_settings_lines_configure_the_same_machine_on_both_paths),
        TH_CASE(test_a_settings_dump_from_the_engine_loads_as_a_config_file),
        TH_CASE(test_both_paths_refuse_the_same_lines_with_the_same_error),
    };
    return th_run(cases, TH_COUNT(cases));
}
