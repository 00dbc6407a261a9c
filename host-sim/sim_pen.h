/*
 * sim_pen.h — when does a machine draw? The pen (or laser) state of a
 * programmed move and of the executed path, for plotters that lift the pen
 * with M3/M5 (a pen or tool line), with Z (pen down at or below a height),
 * and for lasers in Grbl's laser mode ($32=1: the beam fires only on feed
 * moves with M3/M4 and a power S > 0; G0 never fires) (host only).
 *
 * Programmed state: from the program (M3/M5, S, G0/G1, Z). Executed state:
 * from the outputs: the decoded tool line, in Z mode the decoded Z position,
 * for a laser the spindle / laser output (pk_hal_spindle_write: fires while
 * its value is above 0), which is where a laser is wired; if the firmware
 * leaves it on during a G0, the drawing shows the burn it would make.
 */
#ifndef PLOTKIN_SIM_PEN_H
#define PLOTKIN_SIM_PEN_H

#include <stdint.h>

enum pk_pen_mode {
    PK_PEN_TOOL = 0,   /**< M3 = pen down, M5 = pen up (the tool line) */
    PK_PEN_Z = 1,      /**< pen down while Z <= z_down_um (M3/M5 ignored) */
    PK_PEN_LASER = 2   /**< $32=1: fires on G1/G2/G3/G5 moves with M3/M4 and S > 0 */
};

struct pk_pen_cfg {
    uint8_t mode;        /**< enum pk_pen_mode */
    double z_down_um;    /**< PK_PEN_Z: pen-down height, µm */
};

/**
 * Is a programmed move drawn? tool_on: M3/M4 in force; s_power: the S word in
 * force (Grbl starts at 0); rapid: G0; z0_um, z1_um: Z at its start and end.
 * A Z-mode move is drawn when it runs at or below the height all along.
 */
int pk_pen_prog_drawn(const struct pk_pen_cfg *c, int tool_on, double s_power, int rapid, double z0_um,
                      double z1_um);

/** Is the executed path drawing? tool_line: decoded tool line (1 on);
 *  spindle_q16: the spindle / laser output now; z_um: decoded Z. */
int pk_pen_exec_drawn(const struct pk_pen_cfg *c, int tool_line, uint16_t spindle_q16, double z_um);

/** "pen (M3/M5)", "pen at Z <= h", "laser ($32)". */
const char *pk_pen_mode_name(enum pk_pen_mode m);

#endif
