/*
 * state_size.c — compile-time extraction of the kernel's state size.
 *
 * Never run: `make targets` compiles it for each target and configuration
 * (-DPK_AXES, -DPK_WIN) and reads the sizes of these arrays back with
 * `nm -S`, so the figures are those of the target's ABI (alignment, int
 * width), not the host's.
 */
#include "pk_refine.h"

extern const unsigned char pk_size_refine[sizeof(struct pk_refine)];
extern const unsigned char pk_size_level[sizeof(struct pk_level)];
extern const unsigned char pk_size_limit[sizeof(struct pk_limit_stage)];
const unsigned char pk_size_refine[sizeof(struct pk_refine)] = { 1 };
const unsigned char pk_size_level[sizeof(struct pk_level)] = { 1 };
const unsigned char pk_size_limit[sizeof(struct pk_limit_stage)] = { 1 };
