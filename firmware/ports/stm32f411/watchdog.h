/* The independent watchdog (RM0383 §17): started first, then given its period, so that the
 * prescaler and reload updates (which complete only while the watchdog's LSI clock runs) end
 * within a few LSI cycles instead of spinning to their bound; its counter stops while a
 * debugger halts the core (DBGMCU_APB1_FZ, set by the port at boot).
 *
 * Register access goes through WATCHDOG_KEY/WATCHDOG_SR so that the native C tests run this
 * file against a model of the IWDG (tests/firmware/c/test_watchdog.c). */
#ifndef STM32F411_WATCHDOG_H
#define STM32F411_WATCHDOG_H

#include <stdint.h>

/* Periods: prescaler code (LSI / (4 << PR)) and reload (RLR + 1 counts). Running, 32 kHz / 16 x
 * 1001 = ~0.5 s (0.34 s at the LSI's 47 kHz maximum); around a flash erase, 32 kHz / 64 x
 * 4096 = ~8.2 s (5.6 s at 47 kHz). tests/firmware/test_store_watchdog.py reads these to bound
 * the model store's longest stretch without a refresh. */
#define IWDG_RUN_PR 2u
#define IWDG_RUN_RLR 1000u
#define IWDG_ERASE_PR 4u
#define IWDG_ERASE_RLR 4095u
/* Bound on each wait for a prescaler/reload update (status polls; an update takes at most
 * 5 LSI periods, ~300 us at the slowest LSI, a few hundred polls). */
#define IWDG_UPDATE_WAIT 100000u

/* Start the watchdog, then set the running period. Returns the status polls the two update
 * waits took (for the tests: far below IWDG_UPDATE_WAIT once the watchdog runs). */
uint32_t watchdog_start(void);
/* Change the period (refreshed with the old one first); returns the status polls it took. */
uint32_t watchdog_period(uint32_t pr, uint32_t rlr);
void watchdog_refresh(void);

#endif /* STM32F411_WATCHDOG_H */
