#include "watchdog.h"

#ifndef WATCHDOG_KEY /* the chip; the native tests define a model instead */
#include "regs.h"
#define WATCHDOG_KEY(k) (IWDG->KR = (k))
#define WATCHDOG_SR() (IWDG->SR)
#define WATCHDOG_SET(pr, rlr) (IWDG->PR = (pr), IWDG->RLR = (rlr))
#endif

#define KEY_RELOAD 0xAAAAu
#define KEY_UNLOCK 0x5555u
#define KEY_START 0xCCCCu
#define SR_BUSY 3u /* PVU | RVU: a prescaler or reload update in progress */

static uint32_t wait_updates(void) {
    uint32_t i = 0u;
    while (i < IWDG_UPDATE_WAIT && (WATCHDOG_SR() & SR_BUSY) != 0u) {
        i++;
    }
    return i;
}

uint32_t watchdog_period(uint32_t pr, uint32_t rlr) {
    WATCHDOG_KEY(KEY_RELOAD); /* refresh with the old period before changing it */
    uint32_t polls = wait_updates();
    WATCHDOG_KEY(KEY_UNLOCK); /* unlock PR/RLR (RM0383 §17.3) */
    WATCHDOG_SET(pr, rlr);
    polls += wait_updates();
    WATCHDOG_KEY(KEY_RELOAD);
    return polls;
}

uint32_t watchdog_start(void) {
    WATCHDOG_KEY(KEY_START); /* starts the LSI and the counter (default period ~0.5 s) */
    return watchdog_period(IWDG_RUN_PR, IWDG_RUN_RLR);
}

void watchdog_refresh(void) {
    WATCHDOG_KEY(KEY_RELOAD);
}
