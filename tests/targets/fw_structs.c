/*
 * fw_structs.c — compile-time extraction of the sizes of the structs a board
 * image holds in RAM, in that board's ABI and with its size knobs.
 *
 * Never run: hal/firmware.mk compiles it with each board's flags and
 * tests/targets/fwsize.py reads the sizes of these arrays back with nm -S
 * (an array of sizeof(T) bytes has that symbol size).
 */
#include "pk_app.h"

#define PK_SIZEOF(name, type)                                \
    extern const unsigned char pk_sizeof_##name[sizeof(type)]; \
    const unsigned char pk_sizeof_##name[sizeof(type)] = { 1 }

PK_SIZEOF(pk_app, struct pk_app);
PK_SIZEOF(pk_machine, struct pk_machine);
PK_SIZEOF(pk_grbl, struct pk_grbl);
PK_SIZEOF(pk_uart, struct pk_uart);
PK_SIZEOF(pk_grbl_motion, struct pk_grbl_motion);
PK_SIZEOF(pk_stroke, struct pk_stroke);
PK_SIZEOF(pk_refine, struct pk_refine);
PK_SIZEOF(pk_mq, struct pk_mq);
PK_SIZEOF(pk_block, struct pk_block);
PK_SIZEOF(pk_planner, struct pk_planner);
PK_SIZEOF(pk_stepgen, struct pk_stepgen);
PK_SIZEOF(pk_sg_chunk, struct pk_sg_chunk);
PK_SIZEOF(pk_req, struct pk_req);
PK_SIZEOF(pk_gc_state, struct pk_gc_state);
PK_SIZEOF(pk_gc_cmd, struct pk_gc_cmd);
PK_SIZEOF(pk_bez, struct pk_bez);
PK_SIZEOF(pk_grbl_settings, struct pk_grbl_settings);

/* Offsets in struct pk_app of what the AVR benchmark watches in RAM (array
 * size = offset + 1, so that offset 0 is representable). */
#include <stddef.h>
#define PK_OFFSETOF(name, member)                                           \
    extern const unsigned char pk_offsetof_##name[offsetof(struct pk_app, member) + 1]; \
    const unsigned char pk_offsetof_##name[offsetof(struct pk_app, member) + 1] = { 1 }

PK_OFFSETOF(sg_head, m.sg.head);
PK_OFFSETOF(lines_planned, m.lines_planned);
