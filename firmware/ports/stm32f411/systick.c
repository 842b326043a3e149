#include "systick.h"

#include "regs.h"

static volatile uint32_t g_ms;
static uint32_t g_ticks_per_us;
static uint32_t g_reload;

void SysTick_Handler(void) {
    g_ms++;
}

void systick_init(uint32_t sys_hz) {
    g_ticks_per_us = sys_hz / 1000000u;
    g_reload = sys_hz / 1000u - 1u;
    SYSTICK->RVR = g_reload;
    SYSTICK->CVR = 0u;
    SYSTICK->CSR = SYSTICK_CSR_CLKSOURCE | SYSTICK_CSR_TICKINT | SYSTICK_CSR_ENABLE;
}

uint32_t systick_now_us(void) {
    uint32_t ms;
    uint32_t val;
    /* Re-read if the millisecond interrupt ran in between (interrupts are enabled). */
    do {
        ms = g_ms;
        val = SYSTICK->CVR;
    } while (ms != g_ms);
    if (val > g_reload) {
        val = g_reload;
    }
    return ms * 1000u + (g_reload - val) / g_ticks_per_us;
}
