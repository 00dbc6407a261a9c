/*
 * test_fault_injection.c — libgpiod failures at every call site, through the
 * simulator's mock chip (host-sim/gpiod_mock.h), and what the user is left
 * with afterwards.
 *
 * A short pen-plotter job (rapid, pen down, two feed moves, pen up, rapid)
 * runs once cleanly to count the libgpiod calls it makes; then it runs again
 * with exactly one failure planned at each call site: opening the chip, each
 * line request, and each value write (every one of the first 64, then an
 * even sample of the rest, each both as a one-off and as a sticky failure
 * that lasts). After each run:
 *   - a failure during setup is refused cleanly with a message (no machine);
 *   - a failure while running latches ALARM with a reason and a text that
 *     names the failure, and nothing is written to the pins after it;
 *   - the position the firmware reports equals the steps decoded from the
 *     pins (what the motors really did);
 *   - the user can recover: with the fault cleared, a reset and a new move
 *     bring the machine exactly to the new target, counted in whole steps
 *     from the pins.
 * ASan (the sanitized build) checks that no path leaks or touches freed
 * memory.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "sim_run.h"
#include "th.h"

static const char PROGRAM[] = "G21 G90\nG0 X5 Y5\nM3\nG1 X20 Y10 F3000\nG1 X10 Y25\nM5\n"
                              "G0 X1.234 Y2.345\nM2\n";
static const char RECOVER[] = "G21 G90\nG0 X3.3 Y4.4\nG1 X7.77 Y1.11 F2000\nM2\n";

static struct pk_sim_cfg CFG;
static struct pk_sim_result R;

static struct pk_sim_opts opts(const struct pk_gpiod_mock *fault, const char *prog)
{
    struct pk_sim_opts o;
    memset(&o, 0, sizeof o);
    o.chip = "fault-chip";
    o.cfg = &CFG;
    o.program = prog;
    o.len = strlen(prog);
    o.fault = fault;
    struct pk_timing_limits lim = PK_TIMING_DRV8825;
    o.lim = lim;
    o.max_ticks = (uint64_t)CFG.tick_hz * 600u;
    return o;
}

/* round(mm * steps/mm), ties away from zero, in exact integers (µm input) */
static int64_t steps_of(int64_t um, double spmm)
{
    int64_t s = (int64_t)(spmm * 1000.0 + 0.5); /* steps per metre: spmm has <= 3 decimals */
    int64_t num = um * s, den = 1000000;
    return num >= 0 ? (num + den / 2) / den : -((-num + den / 2) / den);
}

struct outcome {
    int setup_failed, alarm;
    uint32_t sets_after_failure;
    int pos_matches;
    int recovered;
};

static struct outcome run_with(const struct pk_gpiod_mock *fault)
{
    struct outcome oc;
    memset(&oc, 0, sizeof oc);
    struct pk_sim_opts o = opts(fault, PROGRAM);
    pk_sim_run(&o, &R);
    if (R.setup_failed) {
        oc.setup_failed = 1;
        TH_EXPECT(R.err[0] != '\0'); /* a message says what failed */
        pk_sim_result_free(&R);
        return oc;
    }
    oc.alarm = R.job.alarm;
    if (oc.alarm)
        TH_EXPECT(R.job.alarm_text[0] != '\0');
    oc.sets_after_failure = R.hw.chip.sets_ok_after_failure;
    oc.pos_matches = 1;
    for (unsigned a = 0; a < CFG.axes; a++)
        if (R.fw_steps[a] != R.dec.pos[a])
            oc.pos_matches = 0;

    /* Recovery, as a user would: clear the fault, reset, send a new job. */
    R.hw.chip.fail_set_nth = 0;
    R.hw.chip.fail_set_sticky = 0;
    pk_machine_reset(&R.m);
    pk_sim_job_free(&R.job);
    pk_sim_job_init(&R.job, &R.m, &CFG, RECOVER, strlen(RECOVER));
    R.run_status = -1;
    while (pk_sim_advance(&R, (uint64_t)CFG.tick_hz) == 0) {
    }
    pk_decoded_free(&R.dec);
    if (pk_sim_finish(&R) == 0) {
        oc.recovered = R.job.alarm == 0 && R.job.errors == 0 &&
                       R.dec.pos[0] == steps_of(7770, CFG.steps_per_mm[0]) &&
                       R.dec.pos[1] == steps_of(1110, CFG.steps_per_mm[1]) &&
                       R.fw_steps[0] == R.dec.pos[0] && R.fw_steps[1] == R.dec.pos[1];
    }
    pk_sim_result_free(&R);
    return oc;
}

static struct pk_gpiod_mock clean_calls(void)
{
    struct pk_sim_opts o = opts(NULL, PROGRAM);
    pk_sim_run(&o, &R);
    struct pk_gpiod_mock seen = R.hw.chip;
    pk_sim_result_free(&R);
    return seen;
}

static void setup_cfg(void)
{
    pk_sim_cfg_default(&CFG);
    CFG.axes = 2;
    CFG.steps_per_mm[1] = 78.74; /* not whole: rounding matters */
}

static void test_the_clean_job_ends_exactly_where_commanded(void)
{
    setup_cfg();
    struct pk_sim_opts o = opts(NULL, PROGRAM);
    pk_sim_run(&o, &R);
    TH_ASSERT(!R.setup_failed);
    TH_EXPECT_EQ(R.job.alarm, 0);
    TH_EXPECT_EQ(R.job.errors, 0);
    TH_EXPECT_EQ(R.dec.pos[0], steps_of(1234, CFG.steps_per_mm[0]));
    TH_EXPECT_EQ(R.dec.pos[1], steps_of(2345, CFG.steps_per_mm[1]));
    TH_EXPECT_EQ(R.fw_steps[0], R.dec.pos[0]);
    TH_EXPECT_EQ(R.dec.n_viol, 0);
    TH_EXPECT(R.hw.chip.calls.set > 1000u); /* enough call sites to be worth sampling */
    pk_sim_result_free(&R);
}

static void test_a_chip_that_cannot_be_opened_is_refused_with_a_message(void)
{
    setup_cfg();
    static const int errs[] = { 2 /* ENOENT */, 13 /* EACCES */, 16 /* EBUSY */ };
    for (unsigned k = 0; k < TH_COUNT(errs); k++) {
        struct pk_gpiod_mock f;
        memset(&f, 0, sizeof f);
        f.fail_open_errno = errs[k];
        struct outcome oc = run_with(&f);
        TH_EXPECT(oc.setup_failed);
    }
}

static void test_every_failing_line_request_is_refused_with_a_message(void)
{
    setup_cfg();
    struct pk_gpiod_mock seen = clean_calls();
    TH_ASSERT(seen.calls.request >= 1u);
    for (uint32_t n = 1; n <= seen.calls.request; n++) {
        struct pk_gpiod_mock f;
        memset(&f, 0, sizeof f);
        f.fail_request_nth = n;
        struct outcome oc = run_with(&f);
        TH_EXPECT(oc.setup_failed);
    }
}

static unsigned faults_injected;

static void test_every_failing_write_ends_in_an_alarm_the_user_recovers_from(void)
{
    setup_cfg();
    struct pk_gpiod_mock seen = clean_calls();
    uint32_t total = seen.calls.set;
    TH_ASSERT(total > 0u);
    unsigned alarms = 0, setups = 0, checked = 0;
    for (uint32_t i = 0; i < 64u + 200u; i++) {
        /* all of the first 64 call sites (setup, first moves), then 200 spread evenly */
        uint32_t n = i < 64u ? i + 1u : 64u + (uint32_t)((uint64_t)(i - 64u) * (total - 64u) / 200u) + 1u;
        if (n > total)
            break;
        for (uint8_t sticky = 0; sticky < 2u; sticky++) {
            struct pk_gpiod_mock f;
            memset(&f, 0, sizeof f);
            f.fail_set_nth = n;
            f.fail_set_sticky = sticky;
            struct outcome oc = run_with(&f);
            faults_injected++;
            checked++;
            if (oc.setup_failed) { /* the initial writes (levels, enable, pen up) */
                setups++;
                continue;
            }
            if (!oc.alarm || !oc.pos_matches || !oc.recovered || oc.sets_after_failure) {
                th_print("  write #");
                th_print_i64(n);
                th_print(sticky ? " (sticky)" : " (once)");
                th_print(": alarm ");
                th_print_i64(oc.alarm);
                th_print(", position matches pins ");
                th_print_i64(oc.pos_matches);
                th_print(", recovered ");
                th_print_i64(oc.recovered);
                th_print(", writes after the failure ");
                th_print_i64(oc.sets_after_failure);
                th_print("\n");
            }
            TH_EXPECT(oc.alarm != 0);            /* a failed write always raises ALARM */
            TH_EXPECT(oc.pos_matches);           /* reported = emitted */
            TH_EXPECT(oc.recovered);             /* reset + new job: exact */
            TH_EXPECT_EQ(oc.sets_after_failure, 0); /* nothing written after the failure */
            alarms += oc.alarm != 0;
        }
    }
    TH_EXPECT(alarms > 400u);
    printf("# %u write faults injected (%u call sites of %u), %u refused at setup, %u alarms\n",
           checked, checked / 2u, (unsigned)total, setups, alarms);
}

int th_main(int argc, char **argv)
{
    (void)argc;
    (void)argv;
    static const struct th_case cases[] = {
        TH_CASE(test_the_clean_job_ends_exactly_where_commanded),
        TH_CASE(test_a_chip_that_cannot_be_opened_is_refused_with_a_message),
        TH_CASE(test_every_failing_line_request_is_refused_with_a_message),
        TH_CASE(test_every_failing_write_ends_in_an_alarm_the_user_recovers_from),
    };
    return th_run(cases, TH_COUNT(cases));
}
