/*
 * test_th_selftest.c — the harness checks itself, on the host and on target.
 *
 * Everything else trusts th to count: a harness that miscounted a failure
 * would turn every test green. So an inner th_run() executes cases whose
 * outcome is known by construction and the outer cases check the counts.
 * The inner run's "not ok"/FAIL lines are deliberate (announced before).
 * It is also the first program of the on-target run (tests/extra/
 * qemu_cortexm.sh), where it exercises 64-bit compares and decimal printing
 * through libgcc on an MCU, and the exit-code path: built with
 * -DTH_SELFTEST_DELIBERATE_FAIL it must fail, and with
 * -DTH_SELFTEST_DELIBERATE_FAULT it must crash into the fault handler,
 * which the script checks.
 */
#include <stdint.h>
#include "th.h"

static unsigned inner_ran;   /* cases of the inner run that started */
static unsigned inner_after; /* statements reached after a failed TH_ASSERT */

static void inner_passes(void) { inner_ran++; TH_EXPECT(1 + 1 == 2); TH_ASSERT_EQ(INT64_MIN, INT64_MIN); }
static void inner_expect_fails_but_continues(void)
{
    inner_ran++;
    TH_EXPECT_EQ(2 + 2, 5);
    TH_EXPECT(1); /* still reached */
}
static void inner_assert_fails_and_stops(void)
{
    inner_ran++;
    TH_ASSERT(0);
    inner_after++;
}
static void inner_high_word_differs(void)
{
    inner_ran++;
    /* Equal in the low 32 bits, different in the high word: must not pass
     * on a 32-bit MCU either. */
    TH_EXPECT_EQ((int64_t)1 << 40, 0);
}
static void inner_passes_last(void) { inner_ran++; TH_EXPECT_EQ(-1, -1); }

static int inner_failed;
static int inner_done;
static void run_inner_once(void)
{
    if (inner_done)
        return;
    inner_done = 1;
    static const struct th_case inner[] = {
        TH_CASE(inner_passes), TH_CASE(inner_expect_fails_but_continues),
        TH_CASE(inner_assert_fails_and_stops), TH_CASE(inner_high_word_differs),
        TH_CASE(inner_passes_last),
    };
    inner_ran = 0;
    inner_after = 0;
    th_print("(inner run: the next 3 failures are deliberate)\n");
    inner_failed = th_run(inner, TH_COUNT(inner));
    th_print("(inner run over)\n");
}

static void test_th_run_returns_the_number_of_failed_cases(void)
{
    run_inner_once();
    TH_ASSERT_EQ(inner_failed, 3);
}

static void test_every_case_runs_even_after_failures(void)
{
    run_inner_once();
    TH_ASSERT_EQ(inner_ran, 5);
}

static void test_a_failed_assert_ends_its_case(void)
{
    run_inner_once();
    TH_ASSERT_EQ(inner_after, 0);
}

static void test_64_bit_checks_compare_all_64_bits(void)
{
    int64_t a = (int64_t)0x7fffffff00000001LL, b = (int64_t)0x0000000000000001LL;
    TH_EXPECT(a != b);
    TH_EXPECT_EQ(a - b, (int64_t)0x7fffffff00000000LL);
    TH_EXPECT_EQ(INT64_MIN / 3, -3074457345618258602LL);
}

#ifdef TH_SELFTEST_DELIBERATE_FAIL
static void test_deliberate_failure_reaches_the_exit_code(void) { TH_EXPECT_EQ(1, 2); }
#endif
#ifdef TH_SELFTEST_DELIBERATE_FAULT
static void test_deliberate_crash_is_not_a_pass(void) { __builtin_trap(); }
#endif

int th_main(int argc, char **argv); /* called by tests/th_host.c or the target start-up */
int th_main(int argc, char **argv)
{
    (void)argc;
    (void)argv;
    static const struct th_case cases[] = {
        TH_CASE(test_th_run_returns_the_number_of_failed_cases),
        TH_CASE(test_every_case_runs_even_after_failures),
        TH_CASE(test_a_failed_assert_ends_its_case),
        TH_CASE(test_64_bit_checks_compare_all_64_bits),
#ifdef TH_SELFTEST_DELIBERATE_FAIL
        TH_CASE(test_deliberate_failure_reaches_the_exit_code),
#endif
#ifdef TH_SELFTEST_DELIBERATE_FAULT
        TH_CASE(test_deliberate_crash_is_not_a_pass),
#endif
    };
    return th_run(cases, TH_COUNT(cases));
}
