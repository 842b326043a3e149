/* Black Pill port: bring up clocks, pins, peripherals; run the core's superloop for ever.
 * The independent watchdog resets the board if a pass ever takes longer than ~0.5 s, which
 * the bounded waits make impossible in normal operation. */
#include <string.h>

#include "generated/board.h"
#include "clock.h"
#include "core_debug.h"
#include "flash_store.h"
#include "gpio.h"
#include "host_link.h"
#include "i2c.h"
#include "pwm.h"
#include "regs.h"
#include "stac_app.h"
#include "systick.h"
#include "uid.h"

#ifndef STAC_BUILD_ID
#define STAC_BUILD_ID "dev"
#endif

static stac_app_t g_app;

static int32_t hal_i2c(void *ctx, uint8_t bus, uint8_t addr7, const uint8_t *wr, uint32_t wr_len,
                       uint8_t *rd, uint32_t rd_len, uint32_t timeout_us) {
    (void)ctx;
    return i2c_transfer(bus, addr7, wr, wr_len, rd, rd_len, timeout_us);
}

static void hal_pwm(void *ctx, uint8_t led, uint8_t colour, uint16_t duty) {
    (void)ctx;
    pwm_set(led, colour, duty);
}

static uint32_t hal_write(void *ctx, const uint8_t *data, uint32_t len) {
    (void)ctx;
    return host_link_write(data, len);
}

static uint32_t hal_read(void *ctx, uint8_t *buf, uint32_t cap) {
    (void)ctx;
    return host_link_read(buf, cap);
}

static uint32_t hal_clock(void *ctx) {
    (void)ctx;
    return systick_now_us();
}

static void hal_uid(void *ctx, uint8_t uid[STAC_UID_SIZE]) {
    (void)ctx;
    uid_read(uid);
}

#define IWDG_SR_BUSY (IWDG_SR_PVU | IWDG_SR_RVU) /* a prescaler or reload update in progress */
/* Watchdog periods, prescaler code (LSI / (4 << PR)) and reload (RLR + 1 counts): running,
 * 32 kHz / 16 x 1001 = ~0.5 s (0.34 s at the LSI's 47 kHz maximum); around a flash erase,
 * 32 kHz / 64 x 4096 = ~8.2 s (5.6 s at 47 kHz). tests/firmware/test_store_watchdog.py reads
 * these to bound the model store's longest stretch without a refresh. */
#define IWDG_RUN_PR 2u
#define IWDG_RUN_RLR 1000u
#define IWDG_ERASE_PR 4u
#define IWDG_ERASE_RLR 4095u
#define IWDG_UPDATE_WAIT 100000u

/* Set the watchdog period: prescaler code (32 kHz / 4 << pr) and reload (RM0383 17.3). */
static void watchdog_period(uint32_t pr, uint32_t rlr) {
    IWDG->KR = IWDG_KR_RELOAD; /* refresh with the old period before changing it */
    for (uint32_t i = 0u; i < IWDG_UPDATE_WAIT && (IWDG->SR & IWDG_SR_BUSY) != 0u; i++) {
    }
    IWDG->KR = IWDG_KR_UNLOCK; /* unlock PR/RLR */
    IWDG->PR = pr;
    IWDG->RLR = rlr;
    for (uint32_t i = 0u; i < IWDG_UPDATE_WAIT && (IWDG->SR & IWDG_SR_BUSY) != 0u; i++) {
    }
    IWDG->KR = IWDG_KR_RELOAD;
}

static void watchdog_start(void) {
    watchdog_period(IWDG_RUN_PR, IWDG_RUN_RLR);
    IWDG->KR = IWDG_KR_START;
}

static uint32_t store_now(void) {
    return systick_now_us();
}

static void store_kick_watchdog(void) {
    IWDG->KR = IWDG_KR_RELOAD;
}

static const flash_store_t k_store = {
    .regs = FLASH_REGS,
    .base = (volatile uint32_t *)FLASH_STORE_ADDR,
    .size = FLASH_STORE_SIZE,
    .sectors = flash_store_sectors,
    .n_sectors = FLASH_STORE_SECTORS,
    .now_us = store_now,
    .before_erase = store_kick_watchdog,
};

static uint32_t hal_store_capacity(void *ctx) {
    (void)ctx;
    return FLASH_STORE_SIZE;
}

static const uint8_t *hal_store_data(void *ctx) {
    (void)ctx;
    return (const uint8_t *)FLASH_STORE_ADDR;
}

/* A sector erase stalls the CPU (code is fetched from the same flash bank) for up to 2 s
 * (128 KiB at x32), and an erase may span all four sectors. The watchdog gets ~8.2 s (still
 * 5.6 s with the LSI at 47 kHz, the top of its range), longer than one sector's erase bound
 * (4 s), and is refreshed before each sector; its usual ~0.5 s comes back after. */
static int32_t hal_store_erase(void *ctx, uint32_t offset, uint32_t len) {
    (void)ctx;
    watchdog_period(IWDG_ERASE_PR, IWDG_ERASE_RLR);
    const int32_t rc = flash_store_erase(&k_store, offset, len);
    watchdog_period(IWDG_RUN_PR, IWDG_RUN_RLR);
    return rc;
}

static int32_t hal_store_program(void *ctx, uint32_t offset, const uint8_t *data, uint32_t len) {
    (void)ctx;
    return flash_store_program(&k_store, offset, data, len);
}

/* The model store's CRC pass refreshes the watchdog between blocks (stac_model_store.c). */
static void hal_watchdog_refresh(void *ctx) {
    (void)ctx;
    IWDG->KR = IWDG_KR_RELOAD;
}

static uint32_t hal_cycles(void *ctx) {
    (void)ctx;
    return cycle_counter_read();
}

int main(void) {
    clocks_t clk;
    clock_init(&clk);
    systick_init(clk.sys_hz);
    gpio_init_board();
    pwm_init(clk.tim_hz);
    i2c_init_all(clk.apb1_hz);
    uint8_t uid[STAC_UID_SIZE];
    uid_read(uid);
    host_link_init(&clk, uid); /* USB: before the watchdog, core set-up waits 25 ms */
    watchdog_start();

    stac_identity_t id;
    memset(&id, 0, sizeof id);
    memcpy(id.board, BOARD_NAME, sizeof BOARD_NAME);
    strncpy(id.build_id, STAC_BUILD_ID, sizeof id.build_id - 1u);
    id.capabilities = STAC_CAPS_CORE | STAC_CAPS_MODEL;
    id.baud = BOARD_BAUD;
    const stac_hal_t hal = {
        .ctx = 0,
        .i2c_transfer = hal_i2c,
        .pwm_set = hal_pwm,
        .link_write = hal_write,
        .link_read = hal_read,
        .clock_us = hal_clock,
        .unique_id = hal_uid,
        .store_capacity = hal_store_capacity,
        .store_data = hal_store_data,
        .store_erase = hal_store_erase,
        .store_program = hal_store_program,
        .watchdog_refresh = hal_watchdog_refresh,
        /* DWT CYCCNT counts core clocks; without one (QEMU) the device reports 0 Hz. */
        .cycles = cycle_counter_start() ? hal_cycles : 0,
        .cycle_hz = clk.sys_hz,
    };
    stac_app_init(&g_app, &hal, &id, systick_now_us());
    for (;;) {
        IWDG->KR = IWDG_KR_RELOAD;
        host_link_service();
        stac_app_step(&g_app, systick_now_us());
    }
}
