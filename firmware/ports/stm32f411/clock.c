#include "clock.h"

#include "generated/board.h"
#include "regs.h"

/* Each ready flag is polled at most this many times (~ms at 16 MHz): a missing crystal or a
 * model without RCC (QEMU) falls back to HSI instead of hanging. The register-level model test
 * (tests/firmware/test_clock_model.py) single-steps clock_init and sets a shorter bound. */
#ifndef READY_SPINS
#define READY_SPINS 200000u
#endif

/* PLL factors and the limits RM0383 §6.3.2 sets on them, checked at compile time: USB full
 * speed needs exactly 48 MHz on PLL48CLK (the crystal's own tolerance aside).
 * tests/firmware/test_clock_spec.py checks these constants against
 * hardware/datasheet_facts.toml ([stm32f411.clock]). */
#define PLL_M 25u
#define PLL_N 192u
#define PLL_P 2u
#define PLL_Q 4u
#define PLL_VCO_IN_HZ (BOARD_HSE_HZ / PLL_M)
#define PLL_VCO_HZ (PLL_VCO_IN_HZ * PLL_N)
#define SYSCLK_HZ (PLL_VCO_HZ / PLL_P)
#define APB1_DIV 2u
#define APB2_DIV 1u
_Static_assert(BOARD_HSE_HZ % PLL_M == 0u, "VCO input must be exact");
_Static_assert(PLL_VCO_IN_HZ >= 1000000u && PLL_VCO_IN_HZ <= 2000000u, "VCO input 1..2 MHz");
_Static_assert(PLL_VCO_HZ >= 100000000u && PLL_VCO_HZ <= 432000000u, "VCO 100..432 MHz");
_Static_assert(SYSCLK_HZ == 96000000u, "SYSCLK 96 MHz (at most 100 MHz)");
_Static_assert(PLL_VCO_HZ % PLL_Q == 0u && PLL_VCO_HZ / PLL_Q == 48000000u,
               "PLL48CLK must be exactly 48 MHz for USB OTG_FS");
_Static_assert(SYSCLK_HZ / APB1_DIV <= 50000000u, "APB1 at most 50 MHz");

/* 96 MHz is above scale 2's 84 MHz (the reset value of PWR_CR.VOS), so the regulator must run
 * in scale 1 (at most 100 MHz), and the flash needs 3 wait states at 2.7..3.6 V (90 < HCLK <=
 * 100 MHz). Both constants are checked against the facts table by the same test. */
#define CLOCK_VOS PWR_CR_VOS_SCALE1
#define CLOCK_FLASH_LATENCY FLASH_ACR_LATENCY_3WS

static int wait_set(volatile uint32_t *reg, uint32_t mask, uint32_t value) {
    for (uint32_t i = 0; i < READY_SPINS; i++) {
        if ((*reg & mask) == value) {
            return 1;
        }
    }
    return 0;
}

/* Back to the reset clocking: the core stays on HSI, PLL and HSE are switched off. With the
 * PLL off the regulator runs in scale 3 whatever VOS says (RM0383 §5.4.1). */
static void fall_back(void) {
    RCC->CR &= ~(RCC_CR_PLLON | RCC_CR_HSEON);
}

void clock_init(clocks_t *out) {
    out->sys_hz = 16000000u;
    out->apb1_hz = 16000000u;
    out->apb2_hz = 16000000u;
    out->tim_hz = 16000000u;
    out->on_pll = 0u;

    RCC->CR |= RCC_CR_HSEON;
    if (!wait_set(&RCC->CR, RCC_CR_HSERDY, RCC_CR_HSERDY)) {
        fall_back();
        return;
    }
    /* Voltage scale 1 before the PLL starts: VOS can only be written while the PLL is off
     * (RM0383 §5.4.1). The PWR interface needs its clock first; the read-back lets the enable
     * take effect before the first PWR write (a write right after it can be lost). */
    RCC->APB1ENR |= RCC_APB1ENR_PWR;
    (void)RCC->APB1ENR;
    PWR->CR = (PWR->CR & ~PWR_CR_VOS_MASK) | CLOCK_VOS;

    /* 25 MHz / M=25 = 1 MHz; x N=192 = 192 MHz VCO; / P=2 = 96 MHz; / Q=4 = 48 MHz (USB).
     * PLLP is encoded (P/2 - 1); PLLSRC selects HSE (RM0383 §6.3.2 RCC_PLLCFGR). */
    RCC->PLLCFGR = (PLL_M << RCC_PLLCFGR_PLLM_SHIFT) | (PLL_N << RCC_PLLCFGR_PLLN_SHIFT) |
                   ((PLL_P / 2u - 1u) << RCC_PLLCFGR_PLLP_SHIFT) | RCC_PLLCFGR_PLLSRC_HSE |
                   (PLL_Q << RCC_PLLCFGR_PLLQ_SHIFT);
    RCC->CR |= RCC_CR_PLLON;
    if (!wait_set(&RCC->CR, RCC_CR_PLLRDY, RCC_CR_PLLRDY)) {
        fall_back();
        return;
    }
    /* The new scale is applied once the PLL runs; VOSRDY says the regulator has reached it.
     * Without it the core must not go above 84 MHz: stay on HSI. */
    if (!wait_set(&PWR->CSR, PWR_CSR_VOSRDY, PWR_CSR_VOSRDY)) {
        fall_back();
        return;
    }
    /* Wait states before the faster clock (RM0383 §3.4.1): read back so the new latency is
     * in force before the switch. */
    FLASH_ACR = CLOCK_FLASH_LATENCY | FLASH_ACR_PRFTEN | FLASH_ACR_ICEN | FLASH_ACR_DCEN;
    if ((FLASH_ACR & FLASH_ACR_LATENCY_MASK) != CLOCK_FLASH_LATENCY) {
        FLASH_ACR = 0u;
        fall_back();
        return;
    }
    RCC->CFGR = RCC_CFGR_PPRE1_DIV2 | RCC_CFGR_SW_PLL; /* APB1 at most 50 MHz */
    if (!wait_set(&RCC->CFGR, RCC_CFGR_SWS_MASK, RCC_CFGR_SWS_PLL)) {
        RCC->CFGR = 0u;
        FLASH_ACR = 0u;
        fall_back();
        return;
    }
    out->sys_hz = SYSCLK_HZ;
    out->apb1_hz = SYSCLK_HZ / APB1_DIV;
    out->apb2_hz = SYSCLK_HZ / APB2_DIV;
    out->tim_hz = SYSCLK_HZ; /* APB1 timers run at twice a divided APB1 */
    out->on_pll = 1u;
}
