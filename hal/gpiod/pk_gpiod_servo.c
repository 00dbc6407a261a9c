/*
 * pk_gpiod_servo.c — a pen servo on a Linux board: the kernel's hardware PWM
 * (the sysfs PWM class, /sys/class/pwm/pwmchipN/pwmM; on a Raspberry Pi GPIO18
 * or GPIO12 with `dtoverlay=pwm`), not a software-timed GPIO line.
 *
 * Why the kernel's PWM: a hobby servo reads its position from a 1-2 ms pulse
 * every 20 ms; 10 µs of jitter is 1 % of its travel. A pulse timed by this
 * process's loop would carry the loop's scheduling jitter (bench-gpiod: p99
 * 2 µs under SCHED_FIFO, milliseconds without it) and need two wake-ups per
 * frame even while the machine idles; the PWM block makes exact frames with no
 * CPU at all, and the firmware only writes a new width (one write of a few
 * bytes) when the pen moves. A board without a PWM pin keeps the pen as a
 * GPIO line (`pen`, a solenoid or a servo driver board).
 *
 * Files of a channel: period and duty_cycle in ns, enable 0/1. The kernel
 * refuses a duty cycle above the period and a period below the duty cycle, so
 * the order is: duty 0 (always valid), period, duty (pen up), enable.
 */
#include "pk_gpiod_servo.h"

#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

static int fail(struct pk_gpiod *g, const char *what, int e)
{
    snprintf(g->err, sizeof g->err, "gpiod: servo PWM %s/%s: %s", g->cfg.servo_pwm, what, strerror(e));
    g->err_op = PK_GPIOD_ERR_TEXT;
    g->err_errno = e;
    g->failures++;
    return PK_HAL_EIO;
}

/* Write a decimal number to DIR/name (or into fd if fd >= 0). 0 or errno. */
static int put(const char *dir, const char *name, int fd, uint32_t v)
{
    char buf[16];
    int n = snprintf(buf, sizeof buf, "%u\n", (unsigned)v); /* as `echo N > file` writes it */
    int own = fd < 0;
    if (own) {
        char path[PK_GPIOD_PATH_MAX + 16];
        snprintf(path, sizeof path, "%s/%s", dir, name);
        fd = open(path, O_WRONLY | O_CLOEXEC);
        if (fd < 0)
            return errno;
    }
    /* sysfs ignores the offset and takes each write whole; rewinding first
     * also makes a regular file (tests) hold the last value, and a FIFO
     * (tests: every value in turn) simply refuses the seek */
    (void)lseek(fd, 0, SEEK_SET);
    errno = 0;
    int e = write(fd, buf, (size_t)n) == n ? 0 : (errno ? errno : EIO);
    if (own)
        close(fd);
    return e;
}

/* The channel's directory is missing: ask its chip to export it (the
 * kernel creates DIR at once; udev may take a moment to open it up). */
static int export_channel(struct pk_gpiod *g)
{
    char parent[PK_GPIOD_PATH_MAX];
    snprintf(parent, sizeof parent, "%s", g->cfg.servo_pwm);
    char *slash = strrchr(parent, '/');
    unsigned ch;
    if (slash == NULL || sscanf(slash + 1, "pwm%u", &ch) != 1)
        return fail(g, "(name)", ENOENT);
    *slash = '\0';
    int e = put(parent, "export", -1, ch);
    if (e != 0 && e != EBUSY)
        return fail(g, "../export", e);
    for (int i = 0; i < 50; i++) { /* up to 0.5 s for udev's permissions */
        char path[PK_GPIOD_PATH_MAX + 16];
        snprintf(path, sizeof path, "%s/duty_cycle", g->cfg.servo_pwm);
        if (access(path, W_OK) == 0)
            return PK_HAL_OK;
        struct timespec ts = { 0, 10000000 };
        nanosleep(&ts, NULL);
    }
    return fail(g, "duty_cycle (after export)", ENOENT);
}

static uint32_t width_ns(const struct pk_gpiod_cfg *c, uint16_t v)
{
    uint32_t span = (c->servo_max_us - c->servo_min_us) * 1000u; /* < 65.5 ms: no overflow below */
    return c->servo_min_us * 1000u + (uint32_t)(((uint64_t)span * v + 32767u) / 65535u);
}

int pk_gpiod_servo_open(struct pk_gpiod *g)
{
    const struct pk_gpiod_cfg *c = &g->cfg;
    char path[PK_GPIOD_PATH_MAX + 16];
    g->servo_fd = -1;
    snprintf(path, sizeof path, "%s/duty_cycle", c->servo_pwm);
    if (access(path, F_OK) != 0 && export_channel(g) != PK_HAL_OK)
        return PK_HAL_EIO;
    int e;
    if ((e = put(c->servo_pwm, "duty_cycle", -1, 0)) != 0)
        return fail(g, "duty_cycle", e);
    if ((e = put(c->servo_pwm, "period", -1, c->servo_frame_us * 1000u)) != 0)
        return fail(g, "period", e);
    g->servo_fd = open(path, O_WRONLY | O_CLOEXEC);
    if (g->servo_fd < 0)
        return fail(g, "duty_cycle", errno);
    g->servo_ns = 0;
    if (pk_gpiod_servo_write(g, 0) != PK_HAL_OK || (e = put(c->servo_pwm, "enable", -1, 1)) != 0) {
        int err = g->err_errno ? g->err_errno : e;
        close(g->servo_fd);
        g->servo_fd = -1;
        return fail(g, "enable", err);
    }
    return PK_HAL_OK;
}

int pk_gpiod_servo_write(struct pk_gpiod *g, uint16_t value_q16)
{
    if (g->servo_fd < 0)
        return PK_HAL_EINVAL;
    uint32_t ns = width_ns(&g->cfg, value_q16);
    if (ns == g->servo_ns)
        return PK_HAL_OK;
    int e = put(NULL, NULL, g->servo_fd, ns);
    if (e != 0)
        return fail(g, "duty_cycle", e);
    g->servo_ns = ns;
    return PK_HAL_OK;
}

void pk_gpiod_servo_close(struct pk_gpiod *g)
{
    if (g->servo_fd < 0)
        return;
    (void)pk_gpiod_servo_write(g, 0);
    (void)put(g->cfg.servo_pwm, "enable", -1, 0);
    close(g->servo_fd);
    g->servo_fd = -1;
}
