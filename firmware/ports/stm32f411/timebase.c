#include "timebase.h"

#include "regs.h"

void timebase_init(uint32_t tim_hz) {
    RCC->APB1ENR |= RCC_APB1ENR_TIM5;
    (void)RCC->APB1ENR; /* let the clock enable take effect before the first TIM5 write */
    TIM5->CR1 = 0u;
    TIM5->PSC = timebase_prescaler(tim_hz);
    TIM5->ARR = 0xFFFFFFFFu; /* free-running over the full 32 bits */
    TIM5->CNT = 0u;
    TIM5->EGR = TIM_EGR_UG; /* load the prescaler now, not at the first overflow */
    TIM5->CR1 = TIM_CR1_CEN;
}

uint32_t timebase_now_us(void) {
    return TIM5->CNT;
}
