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
    uint32_t used[PK_HAL_MAX_AXES * 3 + 1];
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
    for (unsigned i = 0; i < c->axes; i++) {
        used[nu++] = c->step[i];
        used[nu++] = c->dir[i];
    }
    for (unsigned i = 0; i < c->enables; i++)
        used[nu++] = c->enable[i];
    if (c->has_pen)
        used[nu++] = c->pen;
    for (unsigned i = 0; i < nu; i++)
        for (unsigned j = i + 1; j < nu; j++)
            if (used[i] == used[j])
                return fail(err, errlen, 0, "gpiod config: line %u is used twice", (unsigned)used[i]);
    return PK_HAL_OK;
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
        if (nv == 0u)
            return fail(err, errlen, lineno, "'%s' needs a value", key);
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
        } else if (!strcmp(key, "enable")) {
            if (nv > PK_HAL_MAX_AXES)
                return fail(err, errlen, lineno, "'enable': at most %d lines", PK_HAL_MAX_AXES);
            for (unsigned i = 0; i < nv; i++)
                cfg->enable[i] = v[i];
            cfg->enables = (uint8_t)nv;
        } else if (nv != 1u) {
            return fail(err, errlen, lineno, "'%s' takes one value", key);
        } else if (!strcmp(key, "pen")) {
            cfg->pen = v[0];
            cfg->has_pen = 1;
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
    return pk_gpiod_cfg_check(cfg, err, errlen);
}
