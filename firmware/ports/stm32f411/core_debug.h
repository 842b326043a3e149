/* Cortex-M4 core debug registers: the DWT cycle counter (CYCCNT), which the port uses to
 * measure acquisition and decoding on the board itself. Addresses and bits from the ARMv7-M
 * Architecture Reference Manual (ARM DDI 0403E, C1.6 debug registers, C1.8 DWT): DEMCR at
 * 0xE000EDFC, TRCENA bit 24 (enables the DWT and ITM); DWT_CTRL at 0xE0001000 with CYCCNTENA
 * bit 0 and the read-only NOCYCCNT bit 25 (no cycle counter); DWT_CYCCNT at 0xE0001004. The
 * same values as CMSIS's CoreDebug/DWT definitions and independent drivers. They belong to the
 * core, not to ST's peripherals (ST's SVD does not describe them), so they live apart from
 * regs.h. */
#ifndef CORE_DEBUG_H
#define CORE_DEBUG_H

#include <stdbool.h>
#include <stdint.h>

#define CORE_DEMCR (*(volatile uint32_t *)0xE000EDFCu)
#define CORE_DEMCR_TRCENA (1u << 24)
#define DWT_CTRL (*(volatile uint32_t *)0xE0001000u)
#define DWT_CTRL_CYCCNTENA (1u << 0)
#define DWT_CTRL_NOCYCCNT (1u << 25)
#define DWT_CYCCNT (*(volatile uint32_t *)0xE0001004u)

/* Start the cycle counter; true if it exists and counts. A core without one (NOCYCCNT) or an
 * emulator without a DWT (QEMU reads it as 0) gives false: the device then reports its cycle
 * figures as not measured instead of a counter that stands still. */
static inline bool cycle_counter_start(void) {
    CORE_DEMCR |= CORE_DEMCR_TRCENA;
    if ((DWT_CTRL & DWT_CTRL_NOCYCCNT) != 0u) {
        return false;
    }
    DWT_CYCCNT = 0u;
    DWT_CTRL |= DWT_CTRL_CYCCNTENA;
    const uint32_t a = DWT_CYCCNT;
    for (volatile uint32_t i = 0u; i < 16u; i++) {
    }
    return DWT_CYCCNT != a;
}

static inline uint32_t cycle_counter_read(void) {
    return DWT_CYCCNT;
}

#endif /* CORE_DEBUG_H */
