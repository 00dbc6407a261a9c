/*
 * pk_gpiod_cfg.c — the board description of the gpiod backend: defaults, a
 * parser for the small `key value...` text format (see pk_gpiod.h), and the
 * wiring check shared by the parser and pk_gpiod_open.
 */
#include <ctype.h>
#include <errno.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "pk_gpiod.h"

void pk_gpiod_cfg_init(struct pk_gpiod_cfg *cfg)
{
    memset(cfg, 0, sizeof *cfg);
    snprintf(cfg->chip, sizeof cfg->chip, "gpiochip0");
    snprintf(cfg->consumer, sizeof cfg->consumer, "plotkin");
    cfg->servo_min_us = 1000u;
    cfg->servo_max_us = 2000u;
    cfg->servo_frame_us = 20000u;
}

static int fail(char *err, size_t errlen, unsigned line, const char *fmt, ...)
{
    if (err != NULL && errlen > 0u) {
        int k = line ? snprintf(err, errlen, "line %u: ", line) : 0;
        if (k < 0 || (size_t)k >= errlen)
            k = 0;
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(err + k, errlen - (size_t)k, fmt, ap);
        va_end(ap);
    }
    return PK_HAL_EINVAL;
}

int pk_gpiod_cfg_check(const struct pk_gpiod_cfg *c, char *err, size_t errlen)
{
    uint32_t used[PK_HAL_MAX_AXES * 3 + 1 + PK_IN_COUNT];
    unsigned nu = 0;

    if (c->chip[0] == '\0')
        return fail(err, errlen, 0, "gpiod config: no chip given");
    if (c->axes < 1u || c->axes > PK_HAL_MAX_AXES)
        return fail(err, errlen, 0, "gpiod config: need 1..%d step/dir lines (have %u)",
                    PK_HAL_MAX_AXES, (unsigned)c->axes);
    if (c->enables != 0u && c->enables != 1u && c->enables != c->axes)
        return fail(err, errlen, 0, "gpiod config: %u enable lines for %u axes (want 0, 1 or %u)",
                    (unsigned)c->enables, (unsigned)c->axes, (unsigned)c->axes);
    uint32_t axes = ((uint32_t)1 << c->axes) - 1u;
    if ((c->step_invert & ~axes) != 0u || (c->dir_invert & ~axes) != 0u)
        return fail(err, errlen, 0, "gpiod config: invert mask names an axis without lines");
    if ((c->inputs & ~(uint32_t)PK_IN_ALL) != 0u || (c->inputs & PK_IN_LIMITS & ~axes) != 0u)
        return fail(err, errlen, 0, "gpiod config: a limit input for an axis without lines");
    if ((c->input_invert & ~c->inputs) != 0u)
        return fail(err, errlen, 0, "gpiod config: input invert names an input that is not wired");
    if (c->input_bias > 3u)
        return fail(err, errlen, 0, "gpiod config: bad input bias");
    if (c->servo_pwm[0] != '\0') {
        if (c->has_pen)
            return fail(err, errlen, 0, "gpiod config: 'pen' and 'servo_pwm' both given (the pen is one or the other)");
        if (c->servo_min_us < 1u || c->servo_min_us >= c->servo_max_us || c->servo_max_us >= c->servo_frame_us)
            return fail(err, errlen, 0, "gpiod config: want 0 < servo_min_us < servo_max_us < servo_frame_us (%u, %u, %u)",
                        (unsigned)c->servo_min_us, (unsigned)c->servo_max_us, (unsigned)c->servo_frame_us);
    }
    for (unsigned i = 0; i < c->axes; i++) {
        used[nu++] = c->step[i];
        used[nu++] = c->dir[i];
    }
    for (unsigned i = 0; i < c->enables; i++)
        used[nu++] = c->enable[i];
    if (c->has_pen)
        used[nu++] = c->pen;
    for (unsigned b = 0; b < PK_IN_COUNT; b++)
        if ((c->inputs >> b) & 1u)
            used[nu++] = c->input[b];
    for (unsigned i = 0; i < nu; i++)
        for (unsigned j = i + 1; j < nu; j++)
            if (used[i] == used[j])
                return fail(err, errlen, 0, "gpiod config: line %u is used twice", (unsigned)used[i]);
    return PK_HAL_OK;
}

/* The single-line input keys: their enum pk_hal_input, or -1. */
static int input_key(const char *key)
{
    static const char *const names[] = { "probe", "door", "hold", "resume", "reset" };
    for (unsigned i = 0; i < 5u; i++)
        if (!strcmp(key, names[i]))
            return PK_IN_PROBE + (int)i;
    return -1;
}

/* Parse one unsigned number token; 1 on success. */
static int parse_u32(const char *tok, uint32_t max, uint32_t *v)
{
    char *end;
    if (!isdigit((unsigned char)tok[0]))
        return 0;
    errno = 0;
    unsigned long x = strtoul(tok, &end, 10);
    if (errno != 0 || *end != '\0' || x > max)
        return 0;
    *v = (uint32_t)x;
    return 1;
}

int pk_gpiod_cfg_parse(struct pk_gpiod_cfg *cfg, const char *text, char *err, size_t errlen)
{
    unsigned lineno = 0, nstep = 0, ndir = 0;
    const char *p = text;

    while (*p != '\0') {
        char buf[256];
        char *tok[PK_HAL_MAX_AXES + 2];
        unsigned nt = 0;
        size_t len = strcspn(p, "\n");
        lineno++;
        if (len >= sizeof buf)
            return fail(err, errlen, lineno, "line too long");
        memcpy(buf, p, len);
        buf[len] = '\0';
        p += len + (p[len] == '\n');

        char *hash = strchr(buf, '#');
        if (hash)
            *hash = '\0';
        for (char *s = buf; *s; s++)
            if (*s == '=' || *s == '\t' || *s == '\r' || *s == ',')
                *s = ' ';
        char *save = NULL;
        for (char *s = strtok_r(buf, " ", &save); s != NULL; s = strtok_r(NULL, " ", &save)) {
            if (nt == sizeof tok / sizeof tok[0])
                return fail(err, errlen, lineno, "too many values");
            tok[nt++] = s;
        }
        if (nt == 0u)
            continue;
        const char *key = tok[0];
        unsigned nv = nt - 1u;
        uint32_t v[PK_HAL_MAX_AXES + 1];
        int is_text = !strcmp(key, "chip") || !strcmp(key, "consumer");
        if (!strcmp(key, "servo_pwm")) {
            if (nv != 1u || tok[1][0] != '/')
                return fail(err, errlen, lineno, "'servo_pwm' takes one absolute path");
            if (strlen(tok[1]) >= PK_GPIOD_PATH_MAX)
                return fail(err, errlen, lineno, "'servo_pwm' is too long");
            snprintf(cfg->servo_pwm, sizeof cfg->servo_pwm, "%s", tok[1]);
            continue;
        }
        if (nv == 0u)
            return fail(err, errlen, lineno, "'%s' needs a value", key);
        if (!strcmp(key, "input_bias")) {
            static const char *const bias[4] = { "as-is", "pull-up", "pull-down", "disable" };
            unsigned b = 0;
            while (b < 4u && (nv != 1u || strcmp(tok[1], bias[b]) != 0))
                b++;
            if (b == 4u)
                return fail(err, errlen, lineno, "'input_bias' is pull-up, pull-down, disable or as-is");
            cfg->input_bias = (uint8_t)b;
            continue;
        }
        if (is_text) {
            if (nv != 1u)
                return fail(err, errlen, lineno, "'%s' takes one word", key);
            if (strlen(tok[1]) >= PK_GPIOD_NAME_MAX)
                return fail(err, errlen, lineno, "'%s' is too long", key);
            snprintf(!strcmp(key, "chip") ? cfg->chip : cfg->consumer, PK_GPIOD_NAME_MAX, "%s", tok[1]);
            continue;
        }
        for (unsigned i = 0; i < nv; i++)
            if (!parse_u32(tok[i + 1], 0xFFFFu, &v[i]))
                return fail(err, errlen, lineno, "'%s': '%s' is not a number 0..65535", key, tok[i + 1]);
        if (!strcmp(key, "step") || !strcmp(key, "dir")) {
            if (nv > PK_HAL_MAX_AXES)
                return fail(err, errlen, lineno, "'%s': at most %d axes", key, PK_HAL_MAX_AXES);
            uint32_t *dst = key[0] == 's' ? cfg->step : cfg->dir;
            for (unsigned i = 0; i < nv; i++)
                dst[i] = v[i];
            if (key[0] == 's')
                nstep = nv;
            else
                ndir = nv;
            if (nstep != 0u && ndir != 0u && nstep != ndir)
                return fail(err, errlen, lineno, "'dir' lists %u lines, 'step' %u", ndir, nstep);
            if (nstep != 0u)
                cfg->axes = (uint8_t)nstep;
        } else if (!strcmp(key, "limit")) {
            if (nv > PK_HAL_MAX_AXES)
                return fail(err, errlen, lineno, "'limit': at most %d lines, one per axis", PK_HAL_MAX_AXES);
            cfg->inputs &= ~(uint32_t)PK_IN_LIMITS;
            for (unsigned i = 0; i < nv; i++) {
                cfg->input[PK_IN_LIMIT_X + i] = v[i];
                cfg->inputs |= 1u << (PK_IN_LIMIT_X + i);
            }
        } else if (!strcmp(key, "enable")) {
            if (nv > PK_HAL_MAX_AXES)
                return fail(err, errlen, lineno, "'enable': at most %d lines", PK_HAL_MAX_AXES);
            for (unsigned i = 0; i < nv; i++)
                cfg->enable[i] = v[i];
            cfg->enables = (uint8_t)nv;
        } else if (nv != 1u) {
            return fail(err, errlen, lineno, "'%s' takes one value", key);
        } else if (!strcmp(key, "servo_min_us") || !strcmp(key, "servo_max_us") || !strcmp(key, "servo_frame_us")) {
            *(key[6] == 'm' && key[7] == 'i' ? &cfg->servo_min_us
              : key[6] == 'm' ? &cfg->servo_max_us : &cfg->servo_frame_us) = v[0];
        } else if (!strcmp(key, "pen")) {
            cfg->pen = v[0];
            cfg->has_pen = 1;
        } else if (input_key(key) >= 0) {
            unsigned b = (unsigned)input_key(key);
            cfg->input[b] = v[0];
            cfg->inputs |= 1u << b;
        } else if (!strcmp(key, "limit_invert_mask")) {
            if (v[0] > PK_IN_LIMITS)
                return fail(err, errlen, lineno, "'limit_invert_mask' is an axis mask 0..%u", PK_IN_LIMITS);
            cfg->input_invert = (cfg->input_invert & ~(uint32_t)PK_IN_LIMITS) | v[0];
        } else if (!strcmp(key, "probe_invert") || !strcmp(key, "door_invert")
                   || !strcmp(key, "button_invert") || !strcmp(key, "input_edges")) {
            if (v[0] > 1u)
                return fail(err, errlen, lineno, "'%s' is 0 or 1", key);
            uint32_t bits = key[0] == 'p' ? 1u << PK_IN_PROBE
                            : key[0] == 'd' ? 1u << PK_IN_DOOR
                            : (1u << PK_IN_HOLD) | (1u << PK_IN_RESUME) | (1u << PK_IN_RESET);
            if (key[0] == 'i')
                cfg->input_no_edges = v[0] ? 0u : 1u;
            else if (v[0])
                cfg->input_invert |= bits;
            else
                cfg->input_invert &= ~bits;
        } else if (!strcmp(key, "step_invert_mask")) {
            cfg->step_invert = v[0];
        } else if (!strcmp(key, "dir_invert_mask")) {
            cfg->dir_invert = v[0];
        } else if (!strcmp(key, "enable_invert") || !strcmp(key, "pen_invert")) {
            if (v[0] > 1u)
                return fail(err, errlen, lineno, "'%s' is 0 or 1", key);
            if (key[0] == 'e')
                cfg->enable_invert = v[0] ? ((uint32_t)1 << PK_HAL_MAX_AXES) - 1u : 0u;
            else
                cfg->pen_invert = v[0];
        } else {
            return fail(err, errlen, lineno, "unknown key '%s'", key);
        }
    }
    if (ndir != 0u && nstep == 0u && cfg->axes == 0u)
        return fail(err, errlen, 0, "gpiod config: 'dir' given but no 'step' lines");
    /* probe_invert, door_invert, button_invert may name lines not wired */
    cfg->input_invert &= cfg->inputs | PK_IN_LIMITS;
    return pk_gpiod_cfg_check(cfg, err, errlen);
}
