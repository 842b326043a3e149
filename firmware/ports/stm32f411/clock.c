#include "clock.h"

#include "generated/board.h"
#include "regs.h"

/* Each ready flag is polled at most this many times (~ms at 16 MHz): a missing crystal or a
 * model without RCC (QEMU) falls back to HSI instead of hanging. */
#define READY_SPINS 200000u

/* PLL factors and the limits RM0383 §6.3.2 sets on them, checked at compile time: USB full
 * speed needs exactly 48 MHz on PLL48CLK (the crystal's own tolerance aside). */
#define PLL_M 25u
#define PLL_N 192u
#define PLL_P 2u
#define PLL_Q 4u
#define PLL_VCO_IN_HZ (BOARD_HSE_HZ / PLL_M)
#define PLL_VCO_HZ (PLL_VCO_IN_HZ * PLL_N)
_Static_assert(BOARD_HSE_HZ % PLL_M == 0u, "VCO input must be exact");
_Static_assert(PLL_VCO_IN_HZ >= 1000000u && PLL_VCO_IN_HZ <= 2000000u, "VCO input 1..2 MHz");
_Static_assert(PLL_VCO_HZ >= 100000000u && PLL_VCO_HZ <= 432000000u, "VCO 100..432 MHz");
_Static_assert(PLL_VCO_HZ / PLL_P == 96000000u, "SYSCLK 96 MHz (at most 100 MHz)");
_Static_assert(PLL_VCO_HZ % PLL_Q == 0u && PLL_VCO_HZ / PLL_Q == 48000000u,
               "PLL48CLK must be exactly 48 MHz for USB OTG_FS");

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
    /* 25 MHz / M=25 = 1 MHz; x N=192 = 192 MHz VCO; / P=2 = 96 MHz; / Q=4 = 48 MHz (USB).
     * PLLP is encoded (P/2 - 1); PLLSRC (bit 22) selects HSE (RM0383 §6.3.2 RCC_PLLCFGR). */
    RCC->PLLCFGR = PLL_M | (PLL_N << 6) | ((PLL_P / 2u - 1u) << 16) | (1u << 22) | (PLL_Q << 24);
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
