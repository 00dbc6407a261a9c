/*
 * commands.h — the subcommands of the host tool build/plotkin.
 * Each lives in its own host-sim/cmd_*.c; main.c dispatches on argv[1].
 * Exit status convention: 0 success, 1 runtime failure (alarm, I/O),
 * 2 bad usage or bad input.
 */
#ifndef PLOTKIN_COMMANDS_H
#define PLOTKIN_COMMANDS_H

int cmd_refine(int argc, char **argv); /* host-sim/cmd_refine.c */
int cmd_sim(int argc, char **argv);    /* host-sim/cmd_sim.c */
int cmd_serve(int argc, char **argv);  /* host-sim/cmd_serve.c */
int cmd_avrsim(int argc, char **argv); /* host-sim/cmd_avrsim.c */

#endif
