/*
 * pk_gpiod_servo.h — the pen servo of the Linux board backend: a hardware
 * PWM channel of the kernel's sysfs PWM class (private to hal/gpiod/).
 */
#ifndef PLOTKIN_PK_GPIOD_SERVO_H
#define PLOTKIN_PK_GPIOD_SERVO_H

#include <stdint.h>
#include "pk_gpiod.h"

/** struct pk_gpiod.err_op of a failure whose text is g->err as it stands. */
#define PK_GPIOD_ERR_TEXT 1

/** Export the channel if needed, set its period (servo_frame_us), the pen-up
 *  pulse (servo_min_us) and enable it. PK_HAL_OK, or PK_HAL_EIO with the
 *  reason in g->err (nothing left enabled). [MAIN] */
int pk_gpiod_servo_open(struct pk_gpiod *g);

/** Pulse width for a value in Q0.16 of the servo range (0: servo_min_us,
 *  65535: servo_max_us); a write only when the width changes. PK_HAL_OK or
 *  PK_HAL_EIO (reason in g->err). [ISR][MAIN] */
int pk_gpiod_servo_write(struct pk_gpiod *g, uint16_t value_q16);

/** Pen up, disable the channel, close it. Best effort, idempotent. [MAIN] */
void pk_gpiod_servo_close(struct pk_gpiod *g);

#endif
