/*
 * grbl_sim_fixture.h — the Grbl engine + motion core rig (host-sim/grbl_sim.h)
 * as the protocol-level tests drive it: one rig S, everything it answered in
 * out[] (outn bytes, NUL-terminated), and the helpers that move bytes in and
 * out on the simulated clock. Define GRBL_FIXTURE_OUT_SIZE before including
 * to size out[] (default 1 MiB). Static definitions: include once per test
 * program.
 */
#ifndef PLOTKIN_GRBL_SIM_FIXTURE_H
#define PLOTKIN_GRBL_SIM_FIXTURE_H

#include <string.h>
#include "grbl_sim.h"

#ifndef GRBL_FIXTURE_OUT_SIZE
#define GRBL_FIXTURE_OUT_SIZE (1 << 20)
#endif

static struct pk_grbl_sim S;
static char out[GRBL_FIXTURE_OUT_SIZE];
static size_t outn;

#define STEP_TICKS 500u /* main loop every 0.5 ms of simulated time */

/* Take everything the engine has sent into out[]. */
static inline void drain(void)
{
    uint8_t b[128];
    size_t n;
    while ((n = pk_uart_tx_pop(&S.uart, b, sizeof b)) > 0) {
        if (outn + n + 1 < sizeof out) {
            memcpy(out + outn, b, n);
            outn += n;
            out[outn] = 0;
        }
    }
}

/* Run n main-loop periods (with the timer in between), draining after each. */
static inline void step(long n)
{
    for (long i = 0; i < n; i++) {
        pk_grbl_sim_step(&S, STEP_TICKS);
        drain();
    }
}

/* Type s into the UART, waiting (simulated) whenever its ring is full. */
static inline void send(const char *s)
{
    for (; *s; s++) {
        for (int spins = 0; pk_uart_rx_space(&S.uart) == 0 && spins < 100000; spins++)
            step(1);
        pk_uart_rx_push(&S.uart, (uint8_t)*s);
    }
}

/* Non-overlapping occurrences of needle in hay. */
static inline int count(const char *hay, const char *needle)
{
    int c = 0;
    for (const char *p = hay; (p = strstr(p, needle)) != NULL; p += strlen(needle))
        c++;
    return c;
}

#endif
