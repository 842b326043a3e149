#include "pwm.h"

#include "generated/board.h"
#include "regs.h"

static uint32_t g_period; /* timer counts per PWM period (ARR + 1) */

static tim_t *timer(uint8_t unit) {
    return unit == 2u ? TIM2 : unit == 3u ? TIM3 : TIM4;
}

static void timer_setup(tim_t *t) {
    t->CR1 = 0u;
    t->PSC = 0u;
    t->ARR = g_period - 1u;
    for (uint32_t ch = 0; ch < 4u; ch++) {
        t->CCR[ch] = 0u; /* dark until the sequencer says otherwise */
    }
    t->CR1 = TIM_CR1_ARPE;
}

/* PWM mode 1 with preload (a new duty starts at the next period, never mid-pulse) and
 * inverted polarity: the output is active (low, LED on) for CCR counts of each period. */
static void channel_setup(tim_t *t, uint8_t channel) {
    const uint32_t idx = channel - 1u;
    volatile uint32_t *ccmr = idx < 2u ? &t->CCMR1 : &t->CCMR2;
    const uint32_t shift = (idx % 2u) * 8u;
    *ccmr = (*ccmr & ~(TIM_CCMR1_CH1_MASK << shift)) |
            ((TIM_CCMR1_OC1M_PWM1 | TIM_CCMR1_OC1PE) << shift);
    t->CCER |= (TIM_CCER_CC1E | TIM_CCER_CC1P) << (idx * 4u);
}

void pwm_init(uint32_t tim_hz) {
    g_period = tim_hz / BOARD_PWM_HZ;
    RCC->APB1ENR |= RCC_APB1ENR_TIM2 | RCC_APB1ENR_TIM3 | RCC_APB1ENR_TIM4;
    (void)RCC->APB1ENR;
    timer_setup(TIM2);
    timer_setup(TIM3);
    timer_setup(TIM4);
    for (uint32_t i = 0; i < 9u; i++) {
        const board_pin_t *p = &k_board_pins[BOARD_LED_FIRST + i];
        channel_setup(timer(p->unit), p->channel);
    }
    TIM2->EGR = TIM_EGR_UG;
    TIM3->EGR = TIM_EGR_UG;
    TIM4->EGR = TIM_EGR_UG;
    TIM2->CR1 |= TIM_CR1_CEN;
    TIM3->CR1 |= TIM_CR1_CEN;
    TIM4->CR1 |= TIM_CR1_CEN;
}

void pwm_set(uint8_t led, uint8_t colour, uint16_t duty_permille) {
    if (led > 2u || colour > 2u) {
        return;
    }
    const board_pin_t *p = &k_board_pins[BOARD_LED_FIRST + 3u * led + colour];
    const uint32_t duty = duty_permille > 1000u ? 1000u : duty_permille;
    /* 1000 permille gives CCR = period > ARR: output always active, LED fully on. */
    timer(p->unit)->CCR[p->channel - 1u] = duty * g_period / 1000u;
}
