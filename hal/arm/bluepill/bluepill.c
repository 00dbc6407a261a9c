/*
 * bluepill.c — the HAL backend of the Blue Pill board (board.h has the pin
 * map): clocks, pins, the step timer, the serial line, the pen servo and the
 * vector table.
 *
 * Step timer: TIM2 runs freely at 2 MHz; its update interrupt counts wraps,
 * so the clock is (wraps << 16 | CNT), 48 bits; channel 1's compare runs the
 * callback at the tick it asked for. The scheme is the AVR backend's
 * (hal/avr/pk_avr_timer.c): an event further than LEAD ticks ahead is armed
 * on the compare (and run at once if the counter passed it while it was
 * being written), a nearer one is waited for, none is early or lost.
 */
#include <stdint.h>
#include "board.h"
#include "pk_arm.h"

#define LEAD 4u

struct bluepill {
    struct pk_hal hal;
    pk_hal_timer_cb cb;
    void *cb_arg;
    uint32_t next_hi;          /* tick of the pending callback, bits 16..47 */
    uint16_t next_lo;          /*   and bits 0..15 */
    volatile uint32_t ovf;     /* TIM2 wraps (ISR) */
    volatile uint8_t armed;
    struct pk_uart *uart;
};

static struct bluepill board;

/* ---- pins ---------------------------------------------------------------- */

static int bp_step_write(void *ctx, uint32_t mask, uint32_t levels)
{
    (void)ctx;
    mask &= 7u;
    GPIO_BSRR(GPIOA_BASE) = (levels & mask) | ((~levels & mask) << 16);
    return PK_HAL_OK;
}

static int bp_dir_write(void *ctx, uint32_t mask, uint32_t levels)
{
    (void)ctx;
    mask &= 7u;
    GPIO_BSRR(GPIOA_BASE) = ((levels & mask) << 3) | ((~levels & mask) << 19);
    return PK_HAL_OK;
}

static int bp_enable_write(void *ctx, uint32_t mask, uint32_t levels)
{
    (void)ctx;
    if (mask & 7u)
        GPIO_BSRR(GPIOB_BASE) = (levels & mask) ? (1u << 9) : (1u << (9 + 16));
    return PK_HAL_OK;
}

/* ---- pen servo: TIM1 channel 1 PWM, 1 MHz count, 20 ms period, preloaded
 *      compare (a new width starts with the next period) ------------------- */

static int bp_servo_write(void *ctx, uint16_t value_q16)
{
    (void)ctx;
    uint32_t span = PK_BOARD_SERVO_MAX_US - PK_BOARD_SERVO_MIN_US;
    TIM_CCR1(TIM1_BASE) = PK_BOARD_SERVO_MIN_US + ((span * value_q16 + 0x8000u) >> 16);
    return PK_HAL_OK;
}

static int bp_tool_write(void *ctx, uint32_t level) { return bp_servo_write(ctx, level ? 0xFFFFu : 0u); }

/* ---- step timer ------------------------------------------------------------ */

struct tick48 {
    uint32_t hi;
    uint16_t lo;
};

static struct tick48 now_irqoff(void)
{
    struct tick48 t;
    t.lo = (uint16_t)TIM_CNT(TIM2_BASE);
    t.hi = board.ovf;
    if ((TIM_SR(TIM2_BASE) & TIM_SR_UIF) && t.lo < 0x8000u)
        t.hi++;
    return t;
}

static uint64_t t64(struct tick48 t) { return ((uint64_t)t.hi << 16) | t.lo; }

static uint32_t ahead_of(struct tick48 now)
{
    if (board.next_hi == now.hi)
        return board.next_lo > now.lo ? (uint32_t)(board.next_lo - now.lo) : 0u;
    if (board.next_hi == now.hi + 1u)
        return 0x10000u - now.lo + board.next_lo;
    return (int32_t)(board.next_hi - now.hi) > 0 ? 0x20000u : 0u;
}

static int arm(uint32_t d)
{
    TIM_CCR1(TIM2_BASE) = board.next_lo;
    TIM_SR(TIM2_BASE) = ~TIM_SR_CC1IF;
    return d >= 0x8000u || (int16_t)(board.next_lo - (uint16_t)TIM_CNT(TIM2_BASE)) > 0;
}

void pk_board_tim2_irq(void);
void pk_board_tim2_irq(void)
{
    uint32_t sr = TIM_SR(TIM2_BASE);
    if (sr & TIM_SR_UIF) {
        TIM_SR(TIM2_BASE) = ~TIM_SR_UIF;
        board.ovf++;
    }
    if (!(sr & TIM_SR_CC1IF) || !board.armed)
        return;
    TIM_SR(TIM2_BASE) = ~TIM_SR_CC1IF;
    for (;;) {
        struct tick48 now = now_irqoff();
        uint32_t d = ahead_of(now);
        if (d > LEAD) {
            if (arm(d))
                return;
            continue;
        }
        while (d > 0u) {
            now = now_irqoff();
            d = ahead_of(now);
        }
        uint64_t next = board.cb(board.cb_arg, t64(now));
        if (next == 0u) {
            TIM_DIER(TIM2_BASE) &= ~TIM_DIER_CC1IE;
            board.armed = 0u;
            return;
        }
        board.next_lo = (uint16_t)next;
        board.next_hi = (uint32_t)(next >> 16);
    }
}

static int bp_timer_start(void *ctx, pk_hal_timer_cb cb, void *arg, uint64_t first_tick)
{
    (void)ctx;
    if (cb == NULL)
        return PK_HAL_EINVAL;
    uint32_t s = pk_arm_irq_save();
    board.cb = cb;
    board.cb_arg = arg;
    board.next_lo = (uint16_t)first_tick;
    board.next_hi = (uint32_t)(first_tick >> 16);
    board.armed = 1u;
    for (uint32_t margin = LEAD + 1u;; margin *= 2u) {
        struct tick48 now = now_irqoff();
        uint32_t d = ahead_of(now);
        if (d <= LEAD) {
            uint64_t t = t64(now) + margin;
            board.next_lo = (uint16_t)t;
            board.next_hi = (uint32_t)(t >> 16);
            d = margin;
        }
        if (arm(d))
            break;
    }
    TIM_DIER(TIM2_BASE) |= TIM_DIER_CC1IE;
    pk_arm_irq_restore(s);
    return PK_HAL_OK;
}

static int bp_timer_stop(void *ctx)
{
    (void)ctx;
    uint32_t s = pk_arm_irq_save();
    TIM_DIER(TIM2_BASE) &= ~TIM_DIER_CC1IE;
    board.armed = 0u;
    pk_arm_irq_restore(s);
    return PK_HAL_OK;
}

static uint64_t bp_clock(void *ctx)
{
    (void)ctx;
    uint32_t s = pk_arm_irq_save();
    uint64_t t = t64(now_irqoff());
    pk_arm_irq_restore(s);
    return t;
}

static uint32_t bp_irq_save(void *ctx)
{
    (void)ctx;
    return pk_arm_irq_save();
}

static void bp_irq_restore(void *ctx, uint32_t token)
{
    (void)ctx;
    pk_arm_irq_restore(token);
}

/* ---- serial ---------------------------------------------------------------- */

void pk_board_usart1_irq(void);
void pk_board_usart1_irq(void)
{
    uint32_t sr = USART_SR;
    if (sr & (USART_SR_RXNE | USART_SR_ORE)) {
        uint8_t b = (uint8_t)USART_DR; /* reading DR after SR clears RXNE, ORE, FE */
        if (sr & (USART_SR_ORE | USART_SR_FE))
            pk_uart_rx_lost(board.uart);
        if (!(sr & USART_SR_FE))
            (void)pk_uart_rx_push(board.uart, b);
    }
    if ((USART_CR1 & USART_CR1_TXEIE) && (sr & USART_SR_TXE)) {
        uint8_t b;
        if (pk_uart_tx_pop(board.uart, &b, 1u) == 1u)
            USART_DR = b;
        else
            USART_CR1 &= ~USART_CR1_TXEIE;
    }
}

void pk_board_uart_start(struct pk_uart *u)
{
    uint32_t s = pk_arm_irq_save();
    board.uart = u;
    USART_CR1 |= USART_CR1_RXNEIE;
    pk_arm_irq_restore(s);
}

void pk_board_uart_kick(void)
{
    if (board.uart == NULL || pk_uart_tx_space(board.uart) == PK_UART_TX_SIZE)
        return;
    uint32_t s = pk_arm_irq_save();
    USART_CR1 |= USART_CR1_TXEIE;
    pk_arm_irq_restore(s);
}

/* ---- set-up ---------------------------------------------------------------- */

static const struct pk_hal_ops bp_ops = {
    .version = PK_HAL_VERSION,
    .step_write = bp_step_write,
    .dir_write = bp_dir_write,
    .enable_write = bp_enable_write,
    .tool_write = bp_tool_write,
    .spindle_write = bp_servo_write,
    .timer_start = bp_timer_start,
    .timer_stop = bp_timer_stop,
    .clock_ticks = bp_clock,
    .irq_save = bp_irq_save,
    .irq_restore = bp_irq_restore,
};

/* 8 MHz crystal x 9 = 72 MHz; APB1 (TIM2) at 36 MHz, its timers at 72 MHz.
 * A crystal that never starts leaves the image on the 8 MHz RC clock, where
 * nothing is timed right: it then stops before touching the outputs. */
static void clocks_init(void)
{
    FLASH_ACR = 0x12u;                     /* prefetch on, 2 wait states */
    RCC_CR |= 1u << 16;                    /* HSEON */
    for (uint32_t i = 0; !(RCC_CR & (1u << 17)); i++)
        if (i > 1000000u)
            pk_arm_default_handler();
    RCC_CFGR = (7u << 18) | (1u << 16) | (4u << 8); /* PLL x9 from HSE, APB1 /2 */
    RCC_CR |= 1u << 24;                    /* PLLON */
    while (!(RCC_CR & (1u << 25)))
        ;
    RCC_CFGR |= 2u;                        /* SYSCLK = PLL */
    while ((RCC_CFGR & 0xCu) != 0x8u)
        ;
    RCC_APB2ENR |= (1u << 0) | (1u << 2) | (1u << 3) | (1u << 11) | (1u << 14); /* AFIO A B TIM1 USART1 */
    RCC_APB1ENR |= 1u << 0;                /* TIM2 */
}

static void pins_init(void)
{
    GPIO_ODR(GPIOB_BASE) = (1u << 9) | (7u << 12); /* drivers off, limit pull-ups */
    GPIO_BSRR(GPIOA_BASE) = 0x3Fu << 16;           /* step, dir low */
    /* PA0-5 outputs, PA8 TIM1_CH1 (AF push-pull), PA9 TX (AF), PA10 RX (input) */
    GPIO_CRL(GPIOA_BASE) = (GPIO_CRL(GPIOA_BASE) & 0xFF000000u) | 0x00333333u;
    GPIO_CRH(GPIOA_BASE) = (GPIO_CRH(GPIOA_BASE) & 0xFFFFF000u) | 0x000004BBu;
    /* PB9 output, PB12-14 inputs with pull-up */
    GPIO_CRH(GPIOB_BASE) = (GPIO_CRH(GPIOB_BASE) & 0xF000FF0Fu) | 0x08880030u;
}

const struct pk_hal *pk_board_init(void)
{
    clocks_init();
    pins_init();
    board.hal.ops = &bp_ops;
    board.hal.ctx = &board;
    board.hal.tick_hz = PK_BOARD_TICK_HZ;
    board.hal.enable_invert = (1u << PK_BOARD_AXES_WIRED) - 1u;
    /* servo: 72 MHz / 72 = 1 MHz, 20,000 counts, PWM mode 1 preloaded */
    TIM_PSC(TIM1_BASE) = 71u;
    TIM_ARR(TIM1_BASE) = 19999u;
    TIM_CCR1(TIM1_BASE) = PK_BOARD_SERVO_MIN_US;
    TIM_CCMR1(TIM1_BASE) = (6u << 4) | (1u << 3);
    TIM_CCER(TIM1_BASE) = 1u;
    TIM_BDTR(TIM1_BASE) = 1u << 15;
    TIM_EGR(TIM1_BASE) = 1u;
    TIM_CR1(TIM1_BASE) = (1u << 7) | 1u;
    /* step timer: 72 MHz / 36 = 2 MHz, free running, update interrupt */
    TIM_PSC(TIM2_BASE) = 35u;
    TIM_ARR(TIM2_BASE) = 0xFFFFu;
    TIM_EGR(TIM2_BASE) = 1u;
    TIM_SR(TIM2_BASE) = 0u;
    TIM_DIER(TIM2_BASE) = TIM_DIER_UIE;
    TIM_CR1(TIM2_BASE) = 1u;
    /* serial: 72 MHz / 115200 = 625 exactly */
    USART_BRR = 72000000u / PK_BOARD_BAUD;
    USART_CR1 = USART_CR1_UE | USART_CR1_TE | USART_CR1_RE;
    /* the serial line preempts the step callback */
    NVIC_IPR8(IRQ_USART1) = 0x40u;
    NVIC_IPR8(IRQ_TIM2) = 0x80u;
    NVIC_ISER(IRQ_TIM2 / 32u) = 1u << (IRQ_TIM2 % 32u);
    NVIC_ISER(IRQ_USART1 / 32u) = 1u << (IRQ_USART1 % 32u);
    return &board.hal;
}

/* ---- vectors --------------------------------------------------------------- */

extern uint32_t _estack[];
typedef void (*pk_vector)(void);

/* Every slot the default handler, then the board's own (a later designator
 * overrides the range on purpose). */
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Woverride-init"
__attribute__((section(".isr_vector"), used)) static const pk_vector vectors[16 + PK_BOARD_IRQS] = {
    [0] = (pk_vector)(uintptr_t)_estack,
    [1] = pk_arm_reset,
    [2 ... 15 + PK_BOARD_IRQS] = pk_arm_default_handler,
    [16 + IRQ_TIM2] = pk_board_tim2_irq,
    [16 + IRQ_USART1] = pk_board_usart1_irq,
};
#pragma GCC diagnostic pop
