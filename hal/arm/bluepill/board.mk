# hal/arm/bluepill/board.mk — the image for a "Blue Pill" (STM32F103C8,
# Cortex-M3 at 72 MHz; board.h has the pin map). Read by hal/firmware.mk.
#
# Why this Cortex-M: the M3 divides in hardware and multiplies 32x32->64 in one
# instruction (the motion core's 64-bit arithmetic is cheap there, unlike on
# the RP2040's M0+, which has neither), it is the part Grbl's STM32 ports
# (grblHAL's STM32F1xx driver) run on, and QEMU 7.2 has an STM32F1-family
# machine (stm32vldiscovery, an STM32F100) while it has no RP2040 at all.
# That machine models the USARTs only: its TIM1-4, GPIOA-E, RCC and AFIO are
# create_unimplemented_device() stubs (hw/arm/stm32f100_soc.c: reads give 0,
# writes are dropped), so neither the step timer, the pins nor the clock
# start-up of this image can run there; it is linked and sized, not emulated.
BOARD_ARCH  := arm
BOARD_CPU   := -mcpu=cortex-m3 -mthumb -mfloat-abi=soft
BOARD_F_CPU := 72000000UL
BOARD_SRC   := hal/arm/pk_arm_start.c hal/arm/pk_arm_main.c hal/arm/bluepill/bluepill.c \
               hal/pk_app.c hal/pk_uart.c
# Three axes, every scheme the motion core uses, the default queue sizes:
# 20 KB of RAM.
# PK_BUILD_LIMIT=0 (pk_refine_build.h): the kernel's limit/tangent stage and
# its mask tables are for `plotkin refine` and library users; the motion core
# never turns it on (as on the AVR boards). It was 10,212 B of this image's
# 64,612 (924 B were left of the 64 KB part); a limit request is refused
# (tests/e2e_kernel_builds.sh, build full-nolimit: these knobs).
BOARD_DEFS  := -DPK_BUILD_LIMIT=0
BOARD_LDSCRIPT := hal/arm/bluepill/bluepill.ld
BOARD_LDFLAGS  := -nostartfiles --specs=nano.specs
# STM32F103C8 without a bootloader (ST's is in system memory): 64 KB flash,
# 20 KB RAM.
BOARD_FLASH_MAX := 65536
BOARD_RAM_MAX   := 20480
# The object gate (hal/firmware.mk): the step-timer interrupt handler, and the
# image's only statics (the controller and the backend instance).
BOARD_STEP_ISR := pk_board_tim2_irq
BOARD_STATICS  := pk_arm_main.o:app bluepill.o:board
