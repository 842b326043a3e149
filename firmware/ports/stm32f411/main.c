/* Black Pill port: read how the board came up (reset flags, the fault record, the brown-out
 * level), bring up clocks, pins, peripherals; run the core's superloop for ever. The
 * independent watchdog resets the board if a pass ever takes longer than ~0.5 s, which the
 * bounded waits make impossible in normal operation; it stops while a debugger halts the core.
 *
 * Test images (build flag STAC_TEST_COMMANDS, env blackpill_uart_test) also serve DEBUG_FAULT:
 * a HardFault or a hang, for the post-mortem tests and bring-up. */
#include <string.h>

#include "generated/board.h"
#include "boot_record.h"
#include "clock.h"
#include "core_debug.h"
#include "flash_store.h"
#include "gpio.h"
#include "host_link.h"
#include "i2c.h"
#include "pwm.h"
#include "regs.h"
#include "stac_app.h"
#include "timebase.h"
#include "uid.h"
#include "watchdog.h"

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
    return timebase_now_us();
}

static void hal_uid(void *ctx, uint8_t uid[STAC_UID_SIZE]) {
    (void)ctx;
    uid_read(uid);
}

static uint32_t store_now(void) {
    return timebase_now_us();
}

static void store_kick_watchdog(void) {
    watchdog_refresh();
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
    watchdog_refresh();
}

static uint32_t hal_cycles(void *ctx) {
    (void)ctx;
    return cycle_counter_read();
}

/* The ACK of a command that resets the board must leave first (~0.3 ms at 921600 baud). */
#define ACK_FLUSH_US 20000u

static __attribute__((noreturn)) void reset_now(void) {
    __asm volatile("dsb" ::: "memory");
    SCB_AIRCR = SCB_AIRCR_RESET;
    for (;;) {
    }
}

/* ENTER_BOOTLOADER: the reset handler starts the ROM bootloader when it finds the magic. */
static void hal_enter_bootloader(void *ctx) {
    (void)ctx;
    host_link_flush(ACK_FLUSH_US);
    g_boot_record.dfu_magic = BOOT_DFU_MAGIC;
    reset_now();
}

#ifdef STAC_TEST_COMMANDS
/* DEBUG_FAULT (test images): an undefined instruction (UsageFault, escalated to HardFault:
 * CFSR UNDEFINSTR, HFSR FORCED), or a hang with interrupts masked that only the watchdog
 * ends. */
static void hal_debug_fault(void *ctx, uint8_t kind) {
    (void)ctx;
    host_link_flush(ACK_FLUSH_US);
    if (kind == STAC_FAULT_HARD) {
        __asm volatile("udf #0" ::: "memory");
    }
    __asm volatile("cpsid i" ::: "memory");
    for (;;) {
    }
}
#endif

/* Why the board reset and what the last run left behind, read before anything else (the
 * flags stay until RMVF clears them, so each boot reports its own). */
static void read_boot(stac_boot_t *boot) {
    const uint32_t csr = RCC->CSR;
    boot_record_take(&g_boot_record, csr, FLASH_REGS->OPTCR, boot);
    RCC->CSR = csr | RCC_CSR_RMVF;
}

int main(void) {
    DBG_DBGMCU_APB1_FZ |= DBG_DBGMCU_APB1_FZ_DBG_IWDEG_STOP; /* a halted core is not a hang */
    stac_identity_t id;
    memset(&id, 0, sizeof id);
    read_boot(&id.boot);
    clocks_t clk;
    clock_init(&clk);
    timebase_init(clk.tim_hz);
    gpio_init_board();
    pwm_init(clk.tim_hz);
    i2c_init_all(clk.apb1_hz);
    uint8_t uid[STAC_UID_SIZE];
    uid_read(uid);
    host_link_init(&clk, uid); /* USB: before the watchdog, core set-up waits 25 ms */
    (void)watchdog_start();
    /* The crystal's path says nothing; a fallback says which one ran, that USB is off (it
     * needs the crystal's 48 MHz) and the UART's speed error: +0.16 % on the PLL from HSI
     * (the crystal path's divider), +2.1 % on the raw 16 MHz HSI (16 MHz / 17). */
    id.boot.note = clock_note(&clk, BOARD_BAUD);

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
        .enter_bootloader = hal_enter_bootloader,
#ifdef STAC_TEST_COMMANDS
        .debug_fault = hal_debug_fault,
#endif
    };
    stac_app_init(&g_app, &hal, &id, timebase_now_us());
    bool suspended = false;
    for (;;) {
        watchdog_refresh();
        host_link_service();
        /* A suspended USB host reads nothing: pause acquisition with the LEDs dark (the core
         * keeps its clock; the pass after the resume carries on). */
        const bool now_suspended = host_link_suspended() != 0;
        if (now_suspended && !suspended) {
            stac_leds_off(&g_app.leds, &g_app.hal);
        }
        suspended = now_suspended;
        if (!suspended) {
            stac_app_step(&g_app, timebase_now_us());
        }
    }
}
