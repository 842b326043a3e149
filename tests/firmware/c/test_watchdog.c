/* The STM32 port's watchdog (ports/stm32f411/watchdog.c) against a model of the IWDG: its
 * prescaler/reload updates finish only while the watchdog runs (the LSI is started by the
 * START key), so configuring it before starting it spins every update wait to its bound. */
#include <stdbool.h>
#include <stdint.h>

#include "check.h"

static struct {
    bool running;
    bool unlocked;
    uint32_t pr, rlr;
    uint32_t busy_polls; /* status reads left before an update completes (running only) */
    uint32_t keys[16];
    uint32_t n_keys;
} g_iwdg;

static void model_key(uint32_t k) {
    if (g_iwdg.n_keys < 16u) {
        g_iwdg.keys[g_iwdg.n_keys++] = k;
    }
    g_iwdg.running = g_iwdg.running || k == 0xCCCCu;
    g_iwdg.unlocked = k == 0x5555u;
}

static uint32_t model_sr(void) {
    if (g_iwdg.busy_polls > 0u && g_iwdg.running) {
        g_iwdg.busy_polls--;
    }
    return g_iwdg.busy_polls > 0u ? 3u : 0u;
}

static void model_set(uint32_t pr, uint32_t rlr) {
    if (g_iwdg.unlocked) {
        g_iwdg.pr = pr;
        g_iwdg.rlr = rlr;
        g_iwdg.busy_polls = 5u; /* about five LSI periods of polling */
    }
}

#define WATCHDOG_KEY(k) model_key(k)
#define WATCHDOG_SR() model_sr()
#define WATCHDOG_SET(pr, rlr) model_set((pr), (rlr))
#include "watchdog.c"

TEST(watchdog_started_before_its_period_is_set) {
    g_iwdg.running = false;
    g_iwdg.n_keys = 0u;
    g_iwdg.busy_polls = 0u;
    const uint32_t polls = watchdog_start();
    CHECK(g_iwdg.running);
    CHECK_EQ(g_iwdg.keys[0], 0xCCCCu); /* START first */
    CHECK_EQ(g_iwdg.pr, IWDG_RUN_PR);
    CHECK_EQ(g_iwdg.rlr, IWDG_RUN_RLR);
    CHECK(polls < 10u); /* the update waits end with the update, not at their bound */
}

TEST(watchdog_period_change_while_running) {
    (void)watchdog_start();
    const uint32_t polls = watchdog_period(IWDG_ERASE_PR, IWDG_ERASE_RLR);
    CHECK_EQ(g_iwdg.pr, IWDG_ERASE_PR);
    CHECK_EQ(g_iwdg.rlr, IWDG_ERASE_RLR);
    CHECK(polls < 10u);
    CHECK_EQ(g_iwdg.keys[g_iwdg.n_keys - 1u], 0xAAAAu); /* refreshed with the new period */
}

const test_case_t g_watchdog_tests[] = {
    {"watchdog_started_before_its_period_is_set", watchdog_started_before_its_period_is_set},
    {"watchdog_period_change_while_running", watchdog_period_change_while_running},
    {NULL, NULL},
};
