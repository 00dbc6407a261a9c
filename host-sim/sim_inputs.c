/*
 * sim_inputs.c — `plotkin sim`'s input options (see sim_inputs.h).
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "sim_inputs.h"

const char pk_sim_inputs_usage[] =
    "  --input T:NAME=V      at T seconds the input NAME goes to level V (1 active, 0 not)\n"
    "  --switch NAME:AXIS:MM[:-]  NAME is active while AXIS (x, y, z, a) is at MM or\n"
    "                        above it (\":-\": at MM or below); NAME: limit-x limit-y limit-z\n"
    "                        limit-a probe door hold resume reset (all active-low lines)\n"
    "  --hard-limits         hard limits on ($21=1): a limit switch stops the machine\n";

static const char *const names[PK_IN_COUNT] = { "limit-x", "limit-y", "limit-z", "limit-a", "probe",
                                                "door",    "hold",    "resume",  "reset" };

int pk_sim_input_by_name(const char *name)
{
    for (int i = 0; i < PK_IN_COUNT; i++)
        if (!strcmp(name, names[i]))
            return i;
    return -1;
}

static int bad(char *err, size_t n, const char *opt, const char *val, const char *why)
{
    snprintf(err, n, "%s %s: %s", opt, val, why);
    return -1;
}

int pk_sim_inputs_add(struct pk_sim_inputs *s, const char *opt, const char *val, char *err,
                      size_t errlen)
{
    char buf[96];
    if (s->n >= PK_SIM_INPUTS_MAX)
        return bad(err, errlen, opt, val, "too many input options");
    if (strlen(val) >= sizeof buf)
        return bad(err, errlen, opt, val, "too long");
    strcpy(buf, val);
    struct pk_sim_input *in = &s->in[s->n];
    memset(in, 0, sizeof *in);
    char *end;
    if (!strcmp(opt, "--input")) {
        char *colon = strchr(buf, ':'), *eq = strchr(buf, '=');
        if (colon == NULL || eq == NULL || eq < colon)
            return bad(err, errlen, opt, val, "want T:NAME=V");
        *colon = *eq = '\0';
        double t = strtod(buf, &end);
        if (end == buf || *end != '\0' || !(t >= 0.0) || t > 86400.0)
            return bad(err, errlen, opt, val, "T is seconds, 0..86400");
        int k = pk_sim_input_by_name(colon + 1);
        if (k < 0)
            return bad(err, errlen, opt, val, "unknown input name");
        if (strcmp(eq + 1, "0") != 0 && strcmp(eq + 1, "1") != 0)
            return bad(err, errlen, opt, val, "V is 0 or 1");
        in->input = (uint8_t)k;
        in->active = (uint8_t)(eq[1] == '1');
        s->t_s[s->n] = t;
    } else if (!strcmp(opt, "--switch")) {
        char *f[4] = { buf, NULL, NULL, NULL };
        unsigned nf = 1;
        for (char *p = buf; *p && nf < 4; p++)
            if (*p == ':') {
                *p = '\0';
                f[nf++] = p + 1;
            }
        if (nf < 3)
            return bad(err, errlen, opt, val, "want NAME:AXIS:MM[:-]");
        int k = pk_sim_input_by_name(f[0]);
        if (k < 0)
            return bad(err, errlen, opt, val, "unknown input name");
        const char *axes = "xyza";
        if (strlen(f[1]) != 1 || strchr(axes, f[1][0]) == NULL)
            return bad(err, errlen, opt, val, "AXIS is x, y, z or a");
        double mm = strtod(f[2], &end);
        if (end == f[2] || *end != '\0' || !(fabs(mm) <= 2000.0))
            return bad(err, errlen, opt, val, "MM is a position within +-2000 mm");
        if (nf == 4 && strcmp(f[3], "-") != 0 && strcmp(f[3], "+") != 0)
            return bad(err, errlen, opt, val, "the side is + or -");
        in->is_switch = 1;
        in->input = (uint8_t)k;
        in->axis = (uint8_t)(strchr(axes, f[1][0]) - axes);
        in->side = (int8_t)(nf == 4 && f[3][0] == '-' ? -1 : 1);
        s->at_mm[s->n] = mm;
    } else {
        return bad(err, errlen, opt, val, "not an input option");
    }
    s->n++;
    return 0;
}

void pk_sim_inputs_resolve(struct pk_sim_inputs *s, uint32_t tick_hz, const double steps_per_mm[3])
{
    for (size_t k = 0; k < s->n; k++) {
        struct pk_sim_input *in = &s->in[k];
        if (in->is_switch) {
            double spmm = in->axis < 3 ? steps_per_mm[in->axis] : steps_per_mm[0];
            in->at_steps = (int32_t)lround(s->at_mm[k] * spmm);
        } else {
            in->tick = (uint64_t)llround(s->t_s[k] * (double)tick_hz);
        }
    }
}
