/*
 * sim_pen.c — pen and laser state of programmed moves and of the executed
 * path (see sim_pen.h).
 */
#include "sim_pen.h"

int pk_pen_prog_drawn(const struct pk_pen_cfg *c, int tool_on, double s_power, int rapid, double z0_um,
                      double z1_um)
{
    switch (c->mode) {
    case PK_PEN_Z:
        return z0_um <= c->z_down_um && z1_um <= c->z_down_um;
    case PK_PEN_LASER:
        return tool_on && !rapid && s_power > 0.0;
    case PK_PEN_TOOL:
    default:
        return tool_on != 0;
    }
}

int pk_pen_exec_drawn(const struct pk_pen_cfg *c, int tool_line, uint16_t spindle_q16, double z_um)
{
    if (c->mode == PK_PEN_Z)
        return z_um <= c->z_down_um;
    if (c->mode == PK_PEN_LASER)
        return spindle_q16 > 0u;
    return tool_line != 0;
}

const char *pk_pen_mode_name(enum pk_pen_mode m)
{
    switch (m) {
    case PK_PEN_Z: return "pen down at Z <= $208";
    case PK_PEN_LASER: return "laser ($32=1: G1 with M3/M4 and S > 0)";
    case PK_PEN_TOOL:
    default: return "pen on the tool line (M3 down, M5 up)";
    }
}
