/*
 * cm_start.c — bare-metal start-up for the on-target test images (Cortex-M
 * under QEMU, mps2-an385): vector table, reset handler, and the platform
 * side of the test harness through ARM semihosting.
 *
 * No libc: the reset handler copies .data, clears .bss and calls the test
 * program's th_main(); th_write() prints with SYS_WRITE0 (QEMU sends it to
 * stderr) and the result leaves through SYS_EXIT_EXTENDED, so the exit code
 * QEMU returns to the shell is th_main's (the number of failed cases, 0..255).
 * A fault prints its name and exits with PK_CM_EXIT_FAULT, so a crash can
 * never look like a pass. Semihosting needs a debugger or an emulator: under
 * QEMU run with `-semihosting-config enable=on,target=native`.
 */
#include <stdint.h>
#include "th.h"

/** Exit code of an image that took a fault (no test program has 120 cases). */
#define PK_CM_EXIT_FAULT 120

enum { SYS_WRITE0 = 0x04, SYS_EXIT_EXTENDED = 0x20 };
#define ADP_STOPPED_APPLICATION_EXIT 0x20026u

int th_main(int argc, char **argv);
void pk_reset_handler(void);
void pk_fault_handler(void);

static int pk_semihost(int op, const void *arg)
{
    register int r0 __asm__("r0") = op;
    register const void *r1 __asm__("r1") = arg;
    __asm__ volatile("bkpt 0xAB" : "+r"(r0) : "r"(r1) : "memory");
    return r0;
}

void th_write(const char *s) { (void)pk_semihost(SYS_WRITE0, s); }

static void pk_cm_exit(int code)
{
    const uint32_t block[2] = { ADP_STOPPED_APPLICATION_EXIT, (uint32_t)code };
    (void)pk_semihost(SYS_EXIT_EXTENDED, block);
    for (;;) {
    }
}

void pk_fault_handler(void)
{
    th_write("\nFAULT: the image took a HardFault/MemManage/BusFault/UsageFault\n");
    pk_cm_exit(PK_CM_EXIT_FAULT);
}

extern uint32_t __stack_top, __data_load, __data_start, __data_end, __bss_start, __bss_end;

void pk_reset_handler(void)
{
    const uint32_t *src = &__data_load;
    for (uint32_t *d = &__data_start; d < &__data_end;)
        *d++ = *src++;
    for (uint32_t *d = &__bss_start; d < &__bss_end;)
        *d++ = 0;
    static char prog[] = "target";
    char *argv[] = { prog, 0 };
    int failed = th_main(1, argv);
    pk_cm_exit(failed > 255 ? 255 : failed);
}

typedef void (*pk_vector)(void);
__attribute__((section(".vectors"), used))
static const pk_vector pk_vectors[16] = {
    (pk_vector)(uintptr_t)&__stack_top,
    pk_reset_handler,
    pk_fault_handler, /* NMI */
    pk_fault_handler, /* HardFault */
    pk_fault_handler, /* MemManage */
    pk_fault_handler, /* BusFault */
    pk_fault_handler, /* UsageFault */
};
