/*
 * fwcheck_cases.c — known-good and known-bad firmware objects for the gate
 * of `make targets` (tests/targets/fwcheck.py). Each -DCASE_* builds one
 * object that breaks exactly one rule; tests/extra/targets_fwcheck.sh
 * compiles them for every target and checks that the gate names the rule.
 * Without a CASE_* macro the object is clean and must pass, including a
 * step function whose helper only shifts.
 */
#include <stdint.h>
#include <stddef.h>

uint32_t fwc_step(uint32_t acc, uint32_t inc);

#if defined(CASE_STEP_DIVIDE)
/* The divide hides one call deep: the gate must follow the call. 64-bit, so
 * that it is a library call on every target (the M4 divides 32 bits in
 * hardware, which is allowed). */
__attribute__((noinline)) static uint32_t fwc_helper(uint32_t a, uint32_t b)
{
    return (uint32_t)(((uint64_t)a << 8) / (b | 1u));
}
#else
__attribute__((noinline)) static uint32_t fwc_helper(uint32_t a, uint32_t b) { return (a >> 3) + b; }
#endif
uint32_t fwc_step(uint32_t acc, uint32_t inc) { return fwc_helper(acc + inc, inc); }

/* Division outside the step path is allowed. */
uint32_t fwc_plan(uint32_t a, uint32_t b);
uint32_t fwc_plan(uint32_t a, uint32_t b) { return a / (b | 1u); }

#if defined(CASE_HEAP)
void *malloc(size_t n);
void *fwc_alloc(size_t n);
void *fwc_alloc(size_t n) { return malloc(n); }
#elif defined(CASE_STDIO)
int printf(const char *fmt, ...);
void fwc_print(int v);
void fwc_print(int v) { printf("%d\n", v); }
#elif defined(CASE_FLOAT)
int32_t fwc_scale(int32_t v, float k);
int32_t fwc_scale(int32_t v, float k) { return (int32_t)((float)v * k); }
#elif defined(CASE_STATIC)
uint32_t fwc_count(void);
uint32_t fwc_count(void)
{
    static uint32_t n;
    return ++n;
}
#endif
