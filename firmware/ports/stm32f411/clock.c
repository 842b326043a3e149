#include "clock.h"

#include "board.h"
#include "regs.h"

/* Each ready flag is polled at most this many times (~ms at 16 MHz): a missing crystal or a
 * model without RCC (QEMU) falls back to HSI instead of hanging. */
#define READY_SPINS 200000u

static int wait_set(volatile uint32_t *reg, uint32_t mask, uint32_t value) {
    for (uint32_t i = 0; i < READY_SPINS; i++) {
        if ((*reg & mask) == value) {
            return 1;
        }
    }
    return 0;
}

void clock_init(clocks_t *out) {
    out->sys_hz = 16000000u;
    out->apb1_hz = 16000000u;
    out->apb2_hz = 16000000u;
    out->tim_hz = 16000000u;
    out->on_pll = 0u;

    RCC->CR |= RCC_CR_HSEON;
    if (!wait_set(&RCC->CR, RCC_CR_HSERDY, RCC_CR_HSERDY)) {
        RCC->CR &= ~RCC_CR_HSEON;
        return;
    }
    /* 25 MHz / M=25 = 1 MHz; x N=192 = 192 MHz VCO; / P=2 = 96 MHz; / Q=4 = 48 MHz (USB). */
    RCC->PLLCFGR = 25u | (192u << 6) | (0u << 16) | (1u << 22) | (4u << 24);
    RCC->CR |= RCC_CR_PLLON;
    if (!wait_set(&RCC->CR, RCC_CR_PLLRDY, RCC_CR_PLLRDY)) {
        RCC->CR &= ~(RCC_CR_PLLON | RCC_CR_HSEON);
        return;
    }
    /* 96 MHz needs 3 wait states at 3.3 V; set them before switching. */
    FLASH_ACR = FLASH_ACR_LATENCY_3WS | FLASH_ACR_PRFTEN | FLASH_ACR_ICEN | FLASH_ACR_DCEN;
    RCC->CFGR = RCC_CFGR_PPRE1_DIV2 | RCC_CFGR_SW_PLL; /* APB1 at most 50 MHz */
    if (!wait_set(&RCC->CFGR, RCC_CFGR_SWS_MASK, RCC_CFGR_SWS_PLL)) {
        RCC->CFGR = 0u;
        FLASH_ACR = 0u;
        return;
    }
    out->sys_hz = 96000000u;
    out->apb1_hz = 48000000u;
    out->apb2_hz = 96000000u;
    out->tim_hz = 96000000u;
    out->on_pll = 1u;
}
