/*
 * test_gpiod.c — the libgpiod HAL backend against the libgpiod mock: the
 * configuration parser, line requests, bulk writes, polarity, release on
 * shutdown, and every failure path turning into PK_HAL_EIO with a message.
 */
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "th.h"
#include "gpiod/pk_gpiod.h"
#include "gpiod_mock.h"
#include "sim_sched.h"

static const char board_text[] =
    "# a two-axis plotter on a Raspberry Pi\n"
    "chip = pk-test-a\n"
    "consumer plotkin-test\n"
    "step 17 27\n"
    "dir 22, 23   # X Y\n"
    "enable 4\n"
    "pen 18\n"
    "step_invert_mask 2\n"
    "enable_invert 1\n";

static int parse(struct pk_gpiod_cfg *c, const char *text, char *err, size_t n)
{
    pk_gpiod_cfg_init(c);
    return pk_gpiod_cfg_parse(c, text, err, n);
}

static void test_config_text_gives_the_wiring(void)
{
    struct pk_gpiod_cfg c;
    char err[128] = "";
    TH_ASSERT_EQ(parse(&c, board_text, err, sizeof err), PK_HAL_OK);
    TH_EXPECT(strcmp(c.chip, "pk-test-a") == 0);
    TH_EXPECT(strcmp(c.consumer, "plotkin-test") == 0);
    TH_EXPECT_EQ(c.axes, 2);
    TH_EXPECT_EQ(c.step[0], 17);
    TH_EXPECT_EQ(c.step[1], 27);
    TH_EXPECT_EQ(c.dir[0], 22);
    TH_EXPECT_EQ(c.dir[1], 23);
    TH_EXPECT_EQ(c.enables, 1);
    TH_EXPECT_EQ(c.enable[0], 4);
    TH_EXPECT_EQ(c.has_pen, 1);
    TH_EXPECT_EQ(c.pen, 18);
    TH_EXPECT_EQ(c.step_invert, 2);
    TH_EXPECT(c.enable_invert & 1u);
}

static void test_config_errors_name_the_line_and_the_reason(void)
{
    static const struct { const char *text, *want; } bad[] = {
        { "step 1 2\ndir 3 4\nspeed 9\n", "line 3: unknown key 'speed'" },
        { "step 1 2\ndir 3\n", "line 2: 'dir' lists 1 lines, 'step' 2" },
        { "step 1 2\ndir 3 1\n", "line 1 is used twice" },
        { "step 1 x2\n", "line 1: 'step': 'x2' is not a number" },
        { "step 1 2 3 4 5\n", "at most" },
        { "dir 1 2\n", "no 'step' lines" },
        { "chip x\n", "need 1..4 step/dir lines" },
        { "step 1 2\ndir 3 4\nenable 5 6 7\n", "3 enable lines for 2 axes" },
        { "step 1\ndir 2\nstep_invert_mask 2\n", "invert mask names an axis" },
        { "step 1\ndir 2\nchip\n", "line 3: 'chip' needs a value" },
    };
    for (unsigned i = 0; i < TH_COUNT(bad); i++) {
        struct pk_gpiod_cfg c;
        char err[128] = "";
        TH_EXPECT_EQ(parse(&c, bad[i].text, err, sizeof err), PK_HAL_EINVAL);
        TH_EXPECT(strstr(err, bad[i].want) != NULL);
        if (strstr(err, bad[i].want) == NULL) {
            th_print("    got: ");
            th_print(err);
            th_print("\n");
        }
    }
}

/* A test rig: one mock chip + the backend over a scheduler. */
struct rig {
    struct pk_sim_sched sched;
    struct pk_hal base, hal;
    struct pk_gpiod_mock chip;
    struct pk_gpiod g;
    struct pk_gpiod_cfg cfg;
    unsigned changes;
    unsigned last_offset;
    int last_value;
    uint64_t last_t;
};

static void rig_sink(void *arg, unsigned int offset, int value, uint64_t t, int initial)
{
    struct rig *r = arg;
    if (initial)
        return;
    r->changes++;
    r->last_offset = offset;
    r->last_value = value;
    r->last_t = t;
}

static int rig_open(struct rig *r, const char *chip, uint32_t fail_request_nth)
{
    memset(r, 0, sizeof *r);
    pk_sim_sched_init(&r->sched, 1000000u, 10u);
    pk_sim_sched_hal(&r->sched, &r->base);
    pk_gpiod_mock_init(&r->chip, chip, 32);
    r->chip.clock = pk_sim_sched_clock;
    r->chip.clock_arg = &r->sched;
    r->chip.sink = rig_sink;
    r->chip.sink_arg = r;
    r->chip.fail_request_nth = fail_request_nth;
    if (pk_gpiod_mock_register(&r->chip) != 0)
        return -100;
    char err[128];
    pk_gpiod_cfg_init(&r->cfg);
    if (pk_gpiod_cfg_parse(&r->cfg, board_text, err, sizeof err) != PK_HAL_OK)
        return -101;
    snprintf(r->cfg.chip, sizeof r->cfg.chip, "%s", chip);
    return pk_gpiod_open(&r->g, &r->cfg, &r->base, &r->hal);
}

static void rig_close(struct rig *r)
{
    pk_gpiod_close(&r->g);
    pk_gpiod_mock_unregister(&r->chip);
}

static void test_open_requests_every_line_as_output_at_its_idle_level(void)
{
    struct rig r;
    TH_ASSERT_EQ(rig_open(&r, "pk-test-a", 0), PK_HAL_OK);
    TH_EXPECT_EQ(pk_hal_check(&r.hal), PK_HAL_OK);
    TH_EXPECT_EQ(r.chip.requested, 6);
    TH_EXPECT_EQ(r.chip.calls.request, 4); /* step, dir, enable, pen: one bulk each */
    static const unsigned lines[] = { 17, 27, 22, 23, 4, 18 };
    for (unsigned i = 0; i < TH_COUNT(lines); i++) {
        const char *c = pk_gpiod_mock_consumer(&r.chip, lines[i]);
        TH_EXPECT(c != NULL && strcmp(c, "plotkin-test") == 0);
    }
    TH_EXPECT_EQ(pk_gpiod_mock_value(&r.chip, 17), 0); /* X step active-high, idle low */
    TH_EXPECT_EQ(pk_gpiod_mock_value(&r.chip, 27), 1); /* Y step active-low, idle high */
    TH_EXPECT_EQ(pk_gpiod_mock_value(&r.chip, 4), 1);  /* enable active-low: disabled */
    TH_EXPECT_EQ(pk_gpiod_mock_value(&r.chip, 18), 0); /* pen up */
    TH_EXPECT(pk_gpiod_mock_consumer(&r.chip, 5) == NULL);
    TH_EXPECT(strcmp(pk_hal_error_text(&r.hal), "") == 0);
    rig_close(&r);
}

static void test_a_masked_step_write_is_one_bulk_call_and_keeps_other_lines(void)
{
    struct rig r;
    TH_ASSERT_EQ(rig_open(&r, "pk-test-a", 0), PK_HAL_OK);
    uint32_t sets = r.chip.calls.set;
    /* X active (logical 1): raw 1 on 17; Y untouched (still idle high). */
    TH_ASSERT_EQ(pk_hal_step_write(&r.hal, 1u, 1u), PK_HAL_OK);
    TH_EXPECT_EQ(r.chip.calls.set, sets + 1);
    TH_EXPECT_EQ(pk_gpiod_mock_value(&r.chip, 17), 1);
    TH_EXPECT_EQ(pk_gpiod_mock_value(&r.chip, 27), 1);
    /* Y active: active-low, so raw 0; X keeps its level. */
    TH_ASSERT_EQ(pk_hal_step_write(&r.hal, 2u, 2u), PK_HAL_OK);
    TH_EXPECT_EQ(pk_gpiod_mock_value(&r.chip, 17), 1);
    TH_EXPECT_EQ(pk_gpiod_mock_value(&r.chip, 27), 0);
    /* Both inactive in one call. */
    TH_ASSERT_EQ(pk_hal_step_write(&r.hal, 3u, 0u), PK_HAL_OK);
    TH_EXPECT_EQ(r.chip.calls.set, sets + 3);
    TH_EXPECT_EQ(pk_gpiod_mock_value(&r.chip, 17), 0);
    TH_EXPECT_EQ(pk_gpiod_mock_value(&r.chip, 27), 1);
    /* Writing the levels the lines already have costs no call. */
    TH_ASSERT_EQ(pk_hal_step_write(&r.hal, 3u, 0u), PK_HAL_OK);
    TH_EXPECT_EQ(r.chip.calls.set, sets + 3);
    rig_close(&r);
}

static void test_changes_are_stamped_with_the_simulated_time(void)
{
    struct rig r;
    TH_ASSERT_EQ(rig_open(&r, "pk-test-a", 0), PK_HAL_OK);
    TH_ASSERT_EQ(pk_sim_sched_advance(&r.sched, 12345u), PK_SIM_RUN_FINISHED);
    TH_ASSERT_EQ(pk_hal_dir_write(&r.hal, 2u, 2u), PK_HAL_OK);
    TH_EXPECT_EQ(r.changes, 1);
    TH_EXPECT_EQ(r.last_offset, 23);
    TH_EXPECT_EQ(r.last_value, 1);
    TH_EXPECT_EQ(r.last_t, 12345);
    rig_close(&r);
}

static void test_shared_enable_line_and_pen_follow_logical_levels(void)
{
    struct rig r;
    TH_ASSERT_EQ(rig_open(&r, "pk-test-a", 0), PK_HAL_OK);
    TH_ASSERT_EQ(pk_hal_enable_write(&r.hal, 3u, 3u), PK_HAL_OK);
    TH_EXPECT_EQ(pk_gpiod_mock_value(&r.chip, 4), 0); /* enabled = low */
    TH_ASSERT_EQ(pk_hal_tool_write(&r.hal, 1u), PK_HAL_OK);
    TH_EXPECT_EQ(pk_gpiod_mock_value(&r.chip, 18), 1);
    TH_ASSERT_EQ(pk_hal_enable_write(&r.hal, 3u, 0u), PK_HAL_OK);
    TH_EXPECT_EQ(pk_gpiod_mock_value(&r.chip, 4), 1);
    rig_close(&r);
}

static void test_close_releases_every_line_and_leaves_them_idle(void)
{
    struct rig r;
    TH_ASSERT_EQ(rig_open(&r, "pk-test-a", 0), PK_HAL_OK);
    TH_ASSERT_EQ(pk_hal_enable_write(&r.hal, 3u, 3u), PK_HAL_OK);
    TH_ASSERT_EQ(pk_hal_step_write(&r.hal, 3u, 3u), PK_HAL_OK);
    TH_ASSERT_EQ(pk_hal_tool_write(&r.hal, 1u), PK_HAL_OK);
    pk_gpiod_close(&r.g);
    TH_EXPECT_EQ(r.chip.requested, 0);
    TH_EXPECT_EQ(r.chip.is_open, 0);
    TH_EXPECT_EQ(r.chip.calls.close, 1);
    TH_EXPECT_EQ(pk_gpiod_mock_value(&r.chip, 17), 0);
    TH_EXPECT_EQ(pk_gpiod_mock_value(&r.chip, 27), 1);
    TH_EXPECT_EQ(pk_gpiod_mock_value(&r.chip, 4), 1);  /* drivers disabled */
    TH_EXPECT_EQ(pk_gpiod_mock_value(&r.chip, 18), 0); /* pen up */
    pk_gpiod_close(&r.g); /* idempotent */
    TH_EXPECT_EQ(r.chip.calls.close, 1);
    /* After close a write is refused without touching libgpiod. */
    uint32_t sets = r.chip.calls.set;
    TH_EXPECT(pk_hal_step_write(&r.hal, 1u, 1u) != PK_HAL_OK);
    TH_EXPECT_EQ(r.chip.calls.set, sets);
    pk_gpiod_mock_unregister(&r.chip);
}

static void test_a_missing_chip_is_a_clear_error(void)
{
    struct pk_sim_sched s;
    struct pk_hal base, hal;
    struct pk_gpiod g;
    struct pk_gpiod_cfg c;
    char err[128];
    pk_sim_sched_init(&s, 1000000u, 10u);
    pk_sim_sched_hal(&s, &base);
    pk_gpiod_cfg_init(&c);
    TH_ASSERT_EQ(pk_gpiod_cfg_parse(&c, "chip gpiochip9\nstep 1\ndir 2\n", err, sizeof err), PK_HAL_OK);
    TH_ASSERT_EQ(pk_gpiod_open(&g, &c, &base, &hal), PK_HAL_EIO);
    const char *msg = pk_gpiod_error_text(&g);
    TH_EXPECT(strstr(msg, "open chip gpiochip9") != NULL);
    TH_EXPECT(strstr(msg, strerror(ENOENT)) != NULL);
    pk_gpiod_close(&g);
}

static void test_a_failing_line_request_releases_what_was_taken_and_says_which(void)
{
    struct rig r;
    /* The 2nd request (the direction lines) fails as if another program held them. */
    TH_ASSERT_EQ(rig_open(&r, "pk-test-a", 2), PK_HAL_EIO);
    const char *msg = pk_gpiod_error_text(&r.g);
    TH_EXPECT(strstr(msg, "request dir lines 22,23 on pk-test-a") != NULL);
    TH_EXPECT(strstr(msg, strerror(EBUSY)) != NULL);
    TH_EXPECT_EQ(r.chip.requested, 0);
    TH_EXPECT_EQ(r.chip.is_open, 0);
    rig_close(&r);
    TH_EXPECT_EQ(r.chip.calls.close, 1);
}

static void test_a_failing_set_is_eio_with_a_message_and_can_be_retried(void)
{
    struct rig r;
    TH_ASSERT_EQ(rig_open(&r, "pk-test-a", 0), PK_HAL_OK);
    r.chip.fail_set_nth = r.chip.calls.set + 1u;
    TH_EXPECT_EQ(pk_hal_step_write(&r.hal, 1u, 1u), PK_HAL_EIO);
    TH_EXPECT_EQ(pk_gpiod_mock_value(&r.chip, 17), 0);
    TH_EXPECT(strstr(pk_hal_error_text(&r.hal), "set step lines 17,27 on pk-test-a") != NULL);
    TH_EXPECT(strstr(pk_hal_error_text(&r.hal), strerror(EIO)) != NULL);
    /* The shadow was not updated, so the same write is attempted again. */
    TH_EXPECT_EQ(pk_hal_step_write(&r.hal, 1u, 1u), PK_HAL_OK);
    TH_EXPECT_EQ(pk_gpiod_mock_value(&r.chip, 17), 1);
    rig_close(&r);
}

static void test_two_chips_do_not_disturb_each_other(void)
{
    static struct rig a, b;
    TH_ASSERT_EQ(rig_open(&a, "pk-test-a", 0), PK_HAL_OK);
    TH_ASSERT_EQ(rig_open(&b, "pk-test-b", 0), PK_HAL_OK);
    b.chip.fail_set_nth = 1;
    b.chip.fail_set_sticky = 1;
    TH_EXPECT_EQ(pk_hal_step_write(&a.hal, 1u, 1u), PK_HAL_OK);
    TH_EXPECT_EQ(pk_hal_step_write(&b.hal, 1u, 1u), PK_HAL_EIO);
    TH_EXPECT_EQ(pk_gpiod_mock_value(&a.chip, 17), 1);
    TH_EXPECT_EQ(pk_gpiod_mock_value(&b.chip, 17), 0);
    TH_EXPECT_EQ(a.chip.set_failures, 0);
    TH_EXPECT_EQ(b.chip.set_failures, 1);
    TH_EXPECT(strcmp(pk_hal_error_text(&a.hal), "") == 0);
    rig_close(&a);
    TH_EXPECT_EQ(b.chip.requested, 6);
    rig_close(&b);
}

static void test_the_mock_refuses_what_libgpiod_refuses(void)
{
    struct pk_gpiod_mock m;
    struct gpiod_line_bulk bulk, one;
    unsigned int offs[2] = { 3, 5 };
    int vals[2] = { 1, 1 };
    pk_gpiod_mock_init(&m, "pk-test-m", 8);
    TH_ASSERT_EQ(pk_gpiod_mock_register(&m), 0);
    TH_EXPECT_EQ(pk_gpiod_mock_register(&m), -1);
    struct gpiod_chip *chip = gpiod_chip_open_lookup("/dev/pk-test-m");
    TH_ASSERT(chip != NULL);
    errno = 0;
    TH_EXPECT(gpiod_chip_open_lookup("pk-test-m") == NULL && errno == EBUSY);
    TH_ASSERT_EQ(gpiod_chip_get_lines(chip, offs, 2, &bulk), 0);
    errno = 0;
    TH_EXPECT(gpiod_line_set_value_bulk(&bulk, vals) == -1 && errno == EPERM);
    TH_ASSERT_EQ(gpiod_line_request_bulk_output(&bulk, "t", NULL), 0);
    errno = 0;
    TH_EXPECT(gpiod_line_request_bulk_output(&bulk, "t", NULL) == -1 && errno == EBUSY);
    /* A subset of a request is not a valid v1 bulk write. */
    gpiod_line_bulk_init(&one);
    gpiod_line_bulk_add(&one, gpiod_line_bulk_get_line(&bulk, 1));
    errno = 0;
    TH_EXPECT(gpiod_line_set_value_bulk(&one, vals) == -1 && errno == EINVAL);
    TH_EXPECT_EQ(gpiod_line_set_value_bulk(&bulk, vals), 0);
    TH_EXPECT_EQ(pk_gpiod_mock_value(&m, 5), 1);
    unsigned int bad = 8;
    errno = 0;
    TH_EXPECT(gpiod_chip_get_lines(chip, &bad, 1, &one) == -1 && errno == EINVAL);
    gpiod_chip_close(chip);
    TH_EXPECT_EQ(m.requested, 0);
    pk_gpiod_mock_unregister(&m);
    errno = 0;
    TH_EXPECT(gpiod_chip_open_lookup("pk-test-m") == NULL && errno == ENOENT);
}

/* ---- the pen servo on a kernel PWM channel (a fake sysfs directory) ---- */

static void slurp_small(const char *dir, const char *name, char *out, size_t n)
{
    char path[256];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    FILE *f = fopen(path, "r");
    size_t k = f ? fread(out, 1, n - 1, f) : 0;
    out[k] = '\0';
    out[strcspn(out, "\n")] = '\0'; /* sysfs takes "N\n"; a regular file keeps older tails */
    if (f)
        fclose(f);
}

static void touch(const char *dir, const char *name, const char *text)
{
    char path[256];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    FILE *f = fopen(path, "w");
    if (f) {
        fputs(text, f);
        fclose(f);
    }
}

static int servo_open(struct rig *r, const char *chip, const char *pwm_dir, const char *extra)
{
    memset(r, 0, sizeof *r);
    pk_sim_sched_init(&r->sched, 1000000u, 10u);
    pk_sim_sched_hal(&r->sched, &r->base);
    pk_gpiod_mock_init(&r->chip, chip, 32);
    r->chip.clock = pk_sim_sched_clock;
    r->chip.clock_arg = &r->sched;
    if (pk_gpiod_mock_register(&r->chip) != 0)
        return -100;
    char text[512], err[160];
    snprintf(text, sizeof text, "chip %s\nstep 17 27\ndir 22 23\nservo_pwm %s\n%s", chip, pwm_dir, extra);
    pk_gpiod_cfg_init(&r->cfg);
    if (pk_gpiod_cfg_parse(&r->cfg, text, err, sizeof err) != PK_HAL_OK) {
        printf("    %s\n", err);
        return -101;
    }
    return pk_gpiod_open(&r->g, &r->cfg, &r->base, &r->hal);
}

static void test_a_servo_pen_is_a_kernel_pwm_channel_set_in_ns(void)
{
    char dir[] = "/tmp/pk-pwm-XXXXXX", v[32];
    TH_ASSERT(mkdtemp(dir) != NULL);
    touch(dir, "period", "0");
    touch(dir, "duty_cycle", "0");
    touch(dir, "enable", "0");
    struct rig r;
    TH_ASSERT_EQ(servo_open(&r, "pk-test-s", dir, "servo_min_us 900\nservo_max_us 2100\n"), PK_HAL_OK);
    TH_EXPECT(r.hal.ops->spindle_write != NULL);
    slurp_small(dir, "period", v, sizeof v);
    TH_EXPECT(strcmp(v, "20000000") == 0); /* 50 Hz frames, ns */
    slurp_small(dir, "duty_cycle", v, sizeof v);
    TH_EXPECT(strcmp(v, "900000") == 0);   /* opened with the pen up */
    slurp_small(dir, "enable", v, sizeof v);
    TH_EXPECT(strcmp(v, "1") == 0);
    TH_EXPECT_EQ(pk_hal_tool_write(&r.hal, 1), PK_HAL_OK); /* pen down: the far end */
    slurp_small(dir, "duty_cycle", v, sizeof v);
    TH_EXPECT(strcmp(v, "2100000") == 0);
    TH_EXPECT_EQ(pk_hal_spindle_write(&r.hal, 32768), PK_HAL_OK); /* M3 S at half the range */
    slurp_small(dir, "duty_cycle", v, sizeof v);
    TH_EXPECT(strcmp(v, "1500009") == 0); /* 900000 + 1200000 * 32768 / 65535, rounded */
    TH_EXPECT_EQ(pk_hal_tool_write(&r.hal, 0), PK_HAL_OK);
    slurp_small(dir, "duty_cycle", v, sizeof v);
    TH_EXPECT(strcmp(v, "900000") == 0);
    TH_EXPECT_EQ(pk_hal_spindle_write(&r.hal, 16384), PK_HAL_OK); /* S while up: kept, pen stays up */
    slurp_small(dir, "duty_cycle", v, sizeof v);
    TH_EXPECT(strcmp(v, "900000") == 0);
    TH_EXPECT_EQ(pk_hal_tool_write(&r.hal, 1), PK_HAL_OK); /* down at that S */
    slurp_small(dir, "duty_cycle", v, sizeof v);
    TH_EXPECT(strcmp(v, "1200005") == 0); /* 900000 + 1200000 * 16384 / 65535 */
    TH_EXPECT_EQ(pk_hal_tool_write(&r.hal, 0), PK_HAL_OK);
    pk_gpiod_close(&r.g);
    slurp_small(dir, "enable", v, sizeof v);
    TH_EXPECT(strcmp(v, "0") == 0); /* released: no pulses any more */
    pk_gpiod_mock_unregister(&r.chip);
    /* a channel that does not exist and cannot be exported: a clear error, nothing held */
    char missing[300];
    snprintf(missing, sizeof missing, "%s/pwm7", dir);
    touch(dir, "export", "");
    TH_EXPECT_EQ(servo_open(&r, "pk-test-s", missing, ""), PK_HAL_EIO);
    const char *e = pk_gpiod_error_text(&r.g);
    TH_EXPECT(strstr(e, "servo PWM") != NULL && strstr(e, "pwm7") != NULL);
    slurp_small(dir, "export", v, sizeof v);
    TH_EXPECT(strcmp(v, "7") == 0); /* it asked the chip to export channel 7 */
    TH_EXPECT_EQ(r.chip.requested, 0); /* the GPIO lines were released again */
    pk_gpiod_close(&r.g);
    pk_gpiod_mock_unregister(&r.chip);
    /* settings that cannot work are refused when the file is read */
    struct pk_gpiod_cfg c;
    char err[160] = "";
    TH_EXPECT_EQ(parse(&c, "step 1\ndir 2\npen 3\nservo_pwm /x/pwm0\n", err, sizeof err), PK_HAL_EINVAL);
    TH_EXPECT(strstr(err, "both given") != NULL);
    TH_EXPECT_EQ(parse(&c, "step 1\ndir 2\nservo_pwm /x/pwm0\nservo_max_us 25000\n", err, sizeof err),
                 PK_HAL_EINVAL);
    TH_EXPECT(strstr(err, "servo_min_us < servo_max_us < servo_frame_us") != NULL);
    char cmd[400];
    snprintf(cmd, sizeof cmd, "rm -rf %s", dir);
    TH_EXPECT(system(cmd) == 0);
}

int th_main(int argc, char **argv);
int th_main(int argc, char **argv)
{
    (void)argc;
    (void)argv;
    static const struct th_case cases[] = {
        TH_CASE(test_config_text_gives_the_wiring),
        TH_CASE(test_config_errors_name_the_line_and_the_reason),
        TH_CASE(test_open_requests_every_line_as_output_at_its_idle_level),
        TH_CASE(test_a_masked_step_write_is_one_bulk_call_and_keeps_other_lines),
        TH_CASE(test_changes_are_stamped_with_the_simulated_time),
        TH_CASE(test_shared_enable_line_and_pen_follow_logical_levels),
        TH_CASE(test_close_releases_every_line_and_leaves_them_idle),
        TH_CASE(test_a_missing_chip_is_a_clear_error),
        TH_CASE(test_a_failing_line_request_releases_what_was_taken_and_says_which),
        TH_CASE(test_a_failing_set_is_eio_with_a_message_and_can_be_retried),
        TH_CASE(test_two_chips_do_not_disturb_each_other),
        TH_CASE(test_the_mock_refuses_what_libgpiod_refuses),
        TH_CASE(test_a_servo_pen_is_a_kernel_pwm_channel_set_in_ns),
    };
    return th_run(cases, TH_COUNT(cases));
}
