# hal/avr/mega-ramps/board.mk — the image for an Arduino Mega 2560 + RAMPS 1.4
# (board.h has the pin map). Read by hal/firmware.mk: one source list per
# board, the compile-time size knobs of this build, and its budget.
BOARD_ARCH  := avr
BOARD_MCU   := atmega2560
BOARD_F_CPU := 16000000UL
BOARD_SRC   := hal/avr/pk_avr_main.c hal/avr/pk_avr_hal.c hal/avr/pk_avr_timer.c \
               hal/avr/pk_avr_uart.c hal/avr/pk_avr_servo16.c hal/avr/pk_avr_inputs.c \
               hal/avr/pk_avr_nvm.c hal/pk_app.c hal/pk_uart.c
# Three axes, every scheme the motion core uses but degree 7 (PK_WIN=4), depth
# <= 6 and no limit stage (the kernel's exact level cascade keeps 64-bit values:
# 8 levels of 5 would not leave the stack room in 8 KB), queues sized for 8 KB.
# PK_SG_HW_PULSE=1: the AVR HAL ends step pulses itself (step_pulse), so the
# step generator keeps its own pulse-ending path out of the step interrupt;
# PK_SG_PULSE_FN / PK_SG_PULSE_INC: it compiles the HAL's step pulse into its step
# path (hal/avr/pk_avr_pulse.h: no ops table, no call).
# PK_AVR_STEP_INC: the step-timer interrupt compiles the step path into itself
# (hal/avr/pk_avr_step.h, firmware/pk_sg_step.h) instead of calling
# pk_machine_timer_cb -> pk_sg_isr, two call frames of register saves
# (BOARD_SELFTEST_FW: the backend's self test then links the core too).
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
# PK_SG_CHUNKS=16: in the curves of the bundled example at F6000 a block
# lasts a few ms and takes a ring slot of its own besides its segments, so 8
# slots held ~12 ms of motion, less than one stroke-smoothing pass of the main
# loop: the ring ran dry mid-motion 31 times (step gaps of 3-22 ms at up to
# 8,000 steps/s, found in the pin trace; `make bench-avr` counts them). 16:
# 8 times. RAM: 304 B (7,005 of 8,192 B with the deepest stack); a feed
# hold starts within 16 segments (64 ms at speed; Grbl: 6 of up to 10 ms).
BOARD_DEFS  := -DPK_SG_HW_PULSE=1 -DPK_SG_PULSE_FN=pk_avr_step_pulse8_inline -DPK_SG_PULSE_INC='"pk_avr_pulse.h"' -DPK_AVR_STEP_INC='"pk_avr_step.h"' -DPK_SG_FINE_HZ=4000 -DPK_SG_SEG_HZ=250u -DPK_AXES=3 -DPK_MQ_CAP=16 -DPK_SG_CHUNKS=16 -DPK_UART_TX_SIZE=64 -DPK_BUILD_LIMIT=0 -DPK_MAX_DEPTH=6 -DPK_WIN=4 \
               -DPK_GRBL_INPUTS=1
# The host comparator (`plotkin sim` with this build's knobs) has no AVR HAL.
BOARD_SELFTEST_FW := 1
BOARD_HOST_DEFS := -UPK_SG_PULSE_FN -UPK_SG_PULSE_INC -UPK_AVR_STEP_INC
# PK_GRBL_INPUTS=1: limit switches (hard limits, \$H homing) and the probe
# (G38.x) on the RAMPS end stops (board.h), edges on INTn / pin change.
# ATmega2560 with the stock STK500v2 bootloader (8 KB): 262,144 - 8,192 B of
# flash, 8,192 B of RAM.
BOARD_FLASH_MAX := 253952
BOARD_RAM_MAX   := 8192
# The object gate (hal/firmware.mk): the step-timer interrupt handler, and the
# image's only statics (the controller and the backend instance).
BOARD_STEP_ISR := __vector_32
BOARD_STATICS  := pk_avr_main.o:app pk_avr_hal.o:pk_avr_board
