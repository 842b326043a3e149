#include "uid.h"

#include "regs.h"

/* Set by the fault handler when a probing load faulted (startup.c). */
volatile uint32_t g_probe_active;
volatile uint32_t g_probe_faulted;

/* One plain word load: a faulting load is skipped by the handler, so it must not be an
 * instruction with address writeback (a loop's post-increment would then never advance). */
static uint32_t probe_word(uint32_t addr) {
    g_probe_faulted = 0u;
    g_probe_active = 1u;
    const uint32_t v = *(volatile const uint32_t *)addr;
    g_probe_active = 0u;
    return g_probe_faulted != 0u ? 0u : v;
}

void uid_read(uint8_t uid[12]) {
    for (uint32_t w = 0; w < 3u; w++) {
        const uint32_t v = probe_word(UID_BASE + 4u * w);
        for (uint32_t b = 0; b < 4u; b++) {
            uid[4u * w + b] = (uint8_t)(v >> (8u * b));
        }
    }
}
