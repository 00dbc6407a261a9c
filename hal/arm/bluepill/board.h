/*
 * board.h — "Blue Pill" (STM32F103C8, Cortex-M3, 8 MHz crystal, 72 MHz,
 * 64 KB flash, 20 KB RAM) as a plotter controller. This file and
 * bluepill.c are the only places of the image that name its registers,
 * pins, timers and interrupt vectors (no vendor headers: the few registers
 * used are defined here from RM0008).
 *
 *   signal            pin     notes
 *   X / Y / Z step    PA0-PA2 push-pull outputs, one BSRR write for all
 *   X / Y / Z dir     PA3-PA5
 *   steppers enable   PB9     one line for all drivers, active low
 *   pen servo         PA8     TIM1_CH1 hardware PWM, exactly 50 Hz, 1 us steps,
 *                             PK_BOARD_SERVO_MIN_US (value 0, pen up) ..
 *                             PK_BOARD_SERVO_MAX_US
 *   limit X / Y / Z   PB12-14 inputs with pull-ups, not read yet (no homing)
 *   serial            PA9/PA10 USART1, 115200 8N1 (72 MHz / 625 exactly)
 *
 * Timers: TIM2 (16-bit, 72 MHz / 36 = 2 MHz, free running) is the step
 * timer: channel 1 compare schedules the callback, the update (overflow)
 * interrupt extends the count to 48 bits. USART1 has a higher interrupt
 * priority than TIM2, so the serial line preempts the step callback.
 */
#ifndef PLOTKIN_BOARD_BLUEPILL_H
#define PLOTKIN_BOARD_BLUEPILL_H

#include <stdint.h>

#define PK_BOARD_NAME "bluepill"
#define PK_BOARD_AXES_WIRED 3u
#define PK_BOARD_TICK_HZ 2000000u
#define PK_BOARD_BAUD 115200u
#define PK_BOARD_SERVO_MIN_US 1000u
#define PK_BOARD_SERVO_MAX_US 2000u

#define PK_REG(addr) (*(volatile uint32_t *)(uintptr_t)(addr))

/* RCC, flash */
#define RCC_BASE 0x40021000u
#define RCC_CR PK_REG(RCC_BASE + 0x00u)
#define RCC_CFGR PK_REG(RCC_BASE + 0x04u)
#define RCC_APB2ENR PK_REG(RCC_BASE + 0x18u)
#define RCC_APB1ENR PK_REG(RCC_BASE + 0x1Cu)
#define FLASH_ACR PK_REG(0x40022000u)

/* GPIO */
#define GPIOA_BASE 0x40010800u
#define GPIOB_BASE 0x40010C00u
#define GPIO_CRL(b) PK_REG((b) + 0x00u)
#define GPIO_CRH(b) PK_REG((b) + 0x04u)
#define GPIO_ODR(b) PK_REG((b) + 0x0Cu)
#define GPIO_BSRR(b) PK_REG((b) + 0x10u)

/* USART1 */
#define USART1_BASE 0x40013800u
#define USART_SR PK_REG(USART1_BASE + 0x00u)
#define USART_DR PK_REG(USART1_BASE + 0x04u)
#define USART_BRR PK_REG(USART1_BASE + 0x08u)
#define USART_CR1 PK_REG(USART1_BASE + 0x0Cu)
#define USART_SR_FE (1u << 1)
#define USART_SR_ORE (1u << 3)
#define USART_SR_RXNE (1u << 5)
#define USART_SR_TXE (1u << 7)
#define USART_CR1_RE (1u << 2)
#define USART_CR1_TE (1u << 3)
#define USART_CR1_RXNEIE (1u << 5)
#define USART_CR1_TXEIE (1u << 7)
#define USART_CR1_UE (1u << 13)

/* TIM1 (servo) and TIM2 (steps): general timer registers */
#define TIM1_BASE 0x40012C00u
#define TIM2_BASE 0x40000000u
#define TIM_CR1(b) PK_REG((b) + 0x00u)
#define TIM_DIER(b) PK_REG((b) + 0x0Cu)
#define TIM_SR(b) PK_REG((b) + 0x10u)
#define TIM_EGR(b) PK_REG((b) + 0x14u)
#define TIM_CCMR1(b) PK_REG((b) + 0x18u)
#define TIM_CCER(b) PK_REG((b) + 0x20u)
#define TIM_CNT(b) PK_REG((b) + 0x24u)
#define TIM_PSC(b) PK_REG((b) + 0x28u)
#define TIM_ARR(b) PK_REG((b) + 0x2Cu)
#define TIM_CCR1(b) PK_REG((b) + 0x34u)
#define TIM_BDTR(b) PK_REG((b) + 0x44u)
#define TIM_SR_UIF (1u << 0)
#define TIM_SR_CC1IF (1u << 1)
#define TIM_DIER_UIE (1u << 0)
#define TIM_DIER_CC1IE (1u << 1)

/* NVIC, interrupt numbers */
#define NVIC_ISER(n) PK_REG(0xE000E100u + 4u * (n))
#define NVIC_IPR8(irq) (*(volatile uint8_t *)(uintptr_t)(0xE000E400u + (irq)))
#define IRQ_TIM2 28u
#define IRQ_USART1 37u
#define PK_BOARD_IRQS 60u

#endif
