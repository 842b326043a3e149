#include "clock.h"

#include "generated/board.h"
#include "regs.h"
#include "uart.h"

/* Each ready flag is polled at most this many times (~ms at 16 MHz): a missing crystal or a
 * model without RCC (QEMU) falls back instead of hanging. The register-level model test
 * (tests/firmware/test_clock_model.py) single-steps clock_init and sets a shorter bound. */
#ifndef READY_SPINS
#define READY_SPINS 200000u
#endif

#define HSI_HZ 16000000u

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

/* The crystal's fallback: the same 1 MHz VCO input, VCO and SYSCLK from the 16 MHz HSI, so the
 * buses, timers, flash wait states and the UART's divider are those of the crystal's path.
 * PLLQ must still be legal (2..15): 4, so PLL48CLK is a nominal 48 MHz, but only as close as
 * the HSI (~1 %, far outside USB's 0.25 %), so USB is not started on it. */
#define HSI_PLL_M 16u
#define HSI_PLL_VCO_IN_HZ (HSI_HZ / HSI_PLL_M)
_Static_assert(HSI_HZ % HSI_PLL_M == 0u && HSI_PLL_VCO_IN_HZ == PLL_VCO_IN_HZ,
               "the HSI path's VCO input is the crystal path's 1 MHz");
_Static_assert(PLL_Q >= 2u && PLL_Q <= 15u, "PLLQ 2..15 on either path");

/* 25 MHz / M=25 (or 16 MHz / M=16) = 1 MHz; x N=192 = 192 MHz VCO; / P=2 = 96 MHz; / Q=4 =
 * 48 MHz. PLLP is encoded (P/2 - 1); PLLSRC set selects HSE, clear HSI (RM0383 §6.3.2). */
#define PLLCFGR_FACTORS                                                                          \
    ((PLL_N << RCC_PLLCFGR_PLLN_SHIFT) | ((PLL_P / 2u - 1u) << RCC_PLLCFGR_PLLP_SHIFT) |         \
     (PLL_Q << RCC_PLLCFGR_PLLQ_SHIFT))
#define PLLCFGR_FROM_HSE ((PLL_M << RCC_PLLCFGR_PLLM_SHIFT) | RCC_PLLCFGR_PLLSRC_HSE | PLLCFGR_FACTORS)
#define PLLCFGR_FROM_HSI ((HSI_PLL_M << RCC_PLLCFGR_PLLM_SHIFT) | PLLCFGR_FACTORS)

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

/* Back to the reset clocking: the core on HSI, zero wait states (only once the core is slow
 * again, RM0383 §3.4.1), PLL and HSE off, and the PLL stopped (PLLRDY clear) before anyone
 * writes PLLCFGR again (RM0383 §6.3.2: only while the PLL is disabled). With the PLL off the
 * regulator runs in scale 3 whatever VOS says (RM0383 §5.4.1). 1 once the PLL has stopped. */
static int fall_back(void) {
    RCC->CFGR = 0u;
    if (!wait_set(&RCC->CFGR, RCC_CFGR_SWS_MASK, 0u)) {
        return 0; /* still on the PLL: its wait states stay, and so does it */
    }
    FLASH_ACR = 0u;
    RCC->CR &= ~(RCC_CR_PLLON | RCC_CR_HSEON);
    return wait_set(&RCC->CR, RCC_CR_PLLRDY, 0u);
}

/* Start the PLL as `pllcfgr` says (its source already running) and switch the core to it:
 * 1 on success; 0 if a step did not finish within its bound (the caller falls back). */
static int switch_to_pll(uint32_t pllcfgr) {
    /* Voltage scale 1 before the PLL starts: VOS can only be written while the PLL is off
     * (RM0383 §5.4.1). The PWR interface needs its clock first; the read-back lets the enable
     * take effect before the first PWR write (a write right after it can be lost). */
    RCC->APB1ENR |= RCC_APB1ENR_PWR;
    (void)RCC->APB1ENR;
    PWR->CR = (PWR->CR & ~PWR_CR_VOS_MASK) | CLOCK_VOS;
    RCC->PLLCFGR = pllcfgr;
    RCC->CR |= RCC_CR_PLLON;
    if (!wait_set(&RCC->CR, RCC_CR_PLLRDY, RCC_CR_PLLRDY)) {
        return 0;
    }
    /* The new scale is applied once the PLL runs; VOSRDY says the regulator has reached it.
     * Without it the core must not go above 84 MHz: stay on HSI. */
    if (!wait_set(&PWR->CSR, PWR_CSR_VOSRDY, PWR_CSR_VOSRDY)) {
        return 0;
    }
    /* Wait states before the faster clock (RM0383 §3.4.1): read back so the new latency is
     * in force before the switch. */
    FLASH_ACR = CLOCK_FLASH_LATENCY | FLASH_ACR_PRFTEN | FLASH_ACR_ICEN | FLASH_ACR_DCEN;
    if ((FLASH_ACR & FLASH_ACR_LATENCY_MASK) != CLOCK_FLASH_LATENCY) {
        return 0;
    }
    RCC->CFGR = RCC_CFGR_PPRE1_DIV2 | RCC_CFGR_SW_PLL; /* APB1 at most 50 MHz */
    return wait_set(&RCC->CFGR, RCC_CFGR_SWS_MASK, RCC_CFGR_SWS_PLL);
}

void clock_init(clocks_t *out) {
    out->sys_hz = HSI_HZ;
    out->apb1_hz = HSI_HZ;
    out->apb2_hz = HSI_HZ;
    out->tim_hz = HSI_HZ;
    out->source = CLOCK_SRC_HSI;
    out->usb_ok = 0u;

    RCC->CR |= RCC_CR_HSEON;
    if (wait_set(&RCC->CR, RCC_CR_HSERDY, RCC_CR_HSERDY) && switch_to_pll(PLLCFGR_FROM_HSE)) {
        out->source = CLOCK_SRC_HSE_PLL;
        out->usb_ok = 1u;
    } else {
        /* No crystal, or one the PLL could not lock to: the PLL from HSI (the core runs on
         * it, so HSIRDY is set on a chip; a model without RCC reads 0 and stays on HSI). A
         * PLL that does not stop is not reconfigured. */
        if (!fall_back() || !wait_set(&RCC->CR, RCC_CR_HSIRDY, RCC_CR_HSIRDY) ||
            !switch_to_pll(PLLCFGR_FROM_HSI)) {
            (void)fall_back();
            return;
        }
        out->source = CLOCK_SRC_HSI_PLL;
    }
    out->sys_hz = SYSCLK_HZ;
    out->apb1_hz = SYSCLK_HZ / APB1_DIV;
    out->apb2_hz = SYSCLK_HZ / APB2_DIV;
    out->tim_hz = SYSCLK_HZ; /* APB1 timers run at twice a divided APB1 */
}

static char *put_text(char *p, const char *end, const char *t) {
    while (*t != '\0' && p < end) {
        *p++ = *t++;
    }
    return p;
}

static char *put_digits(char *p, const char *end, uint32_t v, uint32_t min_digits) {
    char digits[10];
    uint32_t n = 0u;
    do {
        digits[n++] = (char)('0' + v % 10u);
        v /= 10u;
    } while (v != 0u || n < min_digits);
    while (n > 0u && p < end) {
        *p++ = digits[--n];
    }
    return p;
}

const char *clock_note(const clocks_t *clk, uint32_t baud) {
    static char text[64];
    if (clk->source == CLOCK_SRC_HSE_PLL || baud == 0u) {
        return (const char *)0;
    }
    /* The UART runs at apb2_hz / BRR: its error in thousandths of a percent, rounded to
     * hundredths. 32-bit: the rounded BRR keeps |apb2_hz - BRR x baud| <= baud / 2. */
    const uint32_t ideal = uart_brr(clk->apb2_hz, baud) * baud;
    const int32_t diff = (int32_t)(clk->apb2_hz - ideal);
    const int32_t err = diff * 1000 / (int32_t)(ideal / 100u);
    const uint32_t mag = ((uint32_t)(err < 0 ? -err : err) + 5u) / 10u;
    char *p = text;
    const char *end = text + sizeof text - 1u;
    p = put_text(p, end,
                 clk->source == CLOCK_SRC_HSI_PLL ? "clock HSI+PLL 96MHz (crystal failed)"
                                                  : "clock HSI 16MHz (PLL failed)");
    p = put_text(p, end, ": no USB, UART ");
    p = put_text(p, end, err < 0 ? "-" : "+");
    p = put_digits(p, end, mag / 100u, 1u);
    p = put_text(p, end, ".");
    p = put_digits(p, end, mag % 100u, 2u);
    p = put_text(p, end, "%");
    *p = '\0';
    return text;
}
