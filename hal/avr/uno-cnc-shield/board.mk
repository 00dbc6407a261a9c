# hal/avr/uno-cnc-shield/board.mk — the image for an Arduino Uno + CNC shield V3
# (board.h has the pin map). Read by hal/firmware.mk: one source list per
# board, the compile-time size knobs of this build, and its budget.
BOARD_ARCH  := avr
BOARD_MCU   := atmega328p
BOARD_F_CPU := 16000000UL
BOARD_SRC   := hal/avr/pk_avr_main.c hal/avr/pk_avr_hal.c hal/avr/pk_avr_timer.c \
               hal/avr/pk_avr_uart.c hal/avr/pk_avr_servo8.c hal/avr/pk_avr_nvm.c hal/pk_app.c hal/pk_uart.c
# Two axes + pen. Smoothing in the tolerance mode only (PK_STROKE_FIXED=0:
# \$200=1 is refused), whose kernel is Chaikin with clamped ends on open
# strokes at PK_STROKE_TOL_DEPTH = 3 levels: the kernel's Chaikin-only build
# (pk_refine_chaikin.c), no limit stage, PK_MAX_DEPTH=5: 32-bit working
# values (the tolerance mode needs 3 levels; 5 leaves headroom). It once
# stalled the machine: pk_motion.c saw another struct pk_refine layout than
# the kernel (pk_refine_build.h fixed it; tests/extra/board_refusals.sh runs
# the four-move program that stalled).
# No G2/G3 arcs, no G5/G5.1 (error:20), Grbl's 79-byte line buffer of the
# ATmega328P (a longer line is error:11) and its output staging; short
# queues: see the size table of `make firmware`.
# PK_SG_HW_PULSE=1: the AVR HAL ends step pulses itself (step_pulse), so the
# step generator keeps its own pulse-ending path out of the step interrupt;
# PK_SG_PULSE_FN / PK_SG_PULSE_INC: it compiles the HAL's step pulse into its step
# path (hal/avr/pk_avr_pulse.h: no ops table, no call).
# PK_FLASH_FIRST=1 (pk_munits.h): the chunk preparation's 64-bit helpers stay
# out of line although pk_stepgen.c is compiled for speed (BOARD_HOT_SRC).
# PK_SG_FINE_HZ=4000 (pk_stepgen.h): 2 events per exact step only in blocks
# whose dominant axis steps at most 4 kHz, where a one-event lag is a
# large part of an interval; faster blocks keep one event per step (their
# minor axes lag by up to 250 µs), so the step interrupt is not asked for
# twice the events at speed.
# PK_SG_SEG_HZ=250 (pk_stepgen.h): 4 ms base segments, not 2: each segment
# costs the main loop one preparation whatever its length, and at 2 ms the
# 16 MHz chip spent 10 of the 31 s of the bundled example at F6000 preparing
# them and let the ring run dry (chip 31.44 s against 30.47 s planned, 124
# timer restarts); at 4 ms: 30.67 s against 30.48 s. 2.5 times finer than
# Grbl's 10 ms segments, each with its interval ramp.
BOARD_DEFS  := -DPK_SG_HW_PULSE=1 -DPK_SG_PULSE_FN=pk_avr_step_pulse8_inline -DPK_SG_PULSE_INC='"pk_avr_pulse.h"' -DPK_SG_FINE_HZ=4000 -DPK_SG_SEG_HZ=250u -DPK_FLASH_FIRST=1 -DPK_AXES=2 -DPK_WIN=2 -DPK_MAX_DEPTH=5 -DPK_CLOSE_MAX=3 -DPK_MQ_CAP=8 \
               -DPK_BUILD_DEGREES=0x04 -DPK_BUILD_DLG=0 -DPK_BUILD_ENDS=0x02 -DPK_BUILD_CLOSED=0 -DPK_BUILD_LIMIT=0 \
               -DPK_SG_CHUNKS=4 -DPK_SG_MAX_EVENTS=32 -DPK_STROKE_DEC=16 -DPK_MACHINE_INQ=4 \
               -DPK_UART_TX_SIZE=64 -DPK_STROKE_FIXED=0 -DPK_BUILD_G5=0 -DPK_BUILD_ARCS=0 \
               -DPK_GRBL_LINE_MAX=79 -DPK_GRBL_OUT_SIZE=150
# Shared register save/restore sequences: about 5 % less flash, a few cycles
# more per call of a function that saves many registers. -mstrict-X: pointer
# arithmetic stays off the X register (it has no displacement addressing).
BOARD_CFLAGS := -mcall-prologues -mstrict-X
# Link-time optimisation, and no inlining outside the step path and the
# interrupt handlers (BOARD_HOT_SRC, compiled as on the Mega): flash first
# on this part; the main loop pays a call per small helper.
BOARD_LTO := 1
BOARD_COLD_CFLAGS := -fno-inline
BOARD_HOT_SRC := firmware/pk_stepgen.c hal/avr/pk_avr_timer.c hal/avr/pk_avr_uart.c hal/pk_uart.c
# The host comparator (`plotkin sim` with this build's knobs): plotkin sim's
# job feeds a line only when 5 requests fit (host-sim/sim_job.c), so it needs
# a deeper request FIFO than the Grbl engine on the board; the FIFO depth
# does not change what the engine does.
# (-UPK_SG_PULSE_FN -UPK_SG_PULSE_INC: it has no AVR HAL.)
BOARD_HOST_DEFS := -UPK_MACHINE_INQ -DPK_MACHINE_INQ=8 -UPK_SG_PULSE_FN -UPK_SG_PULSE_INC
# ATmega328P with Optiboot (512 B): 32,768 - 512 B of flash, 2,048 B of RAM.
BOARD_FLASH_MAX := 32256
BOARD_RAM_MAX   := 2048
# The object gate (hal/firmware.mk): the step-timer interrupt handler, and the
# image's only statics (the controller and the backend instance).
BOARD_STEP_ISR := __vector_11
BOARD_STATICS  := pk_avr_main.o:app pk_avr_hal.o:pk_avr_board
