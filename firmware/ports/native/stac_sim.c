/* Native port: adapts caller-supplied callbacks (or the VEML3328 models beside it, veml_model.c)
 * to the core's HAL, one instance per device. The ABI (generated/stac_sim.h) is generated from
 * hardware/definitions/sim_abi.toml. */
#include "generated/stac_sim.h"

#include <stdio.h>
#include <string.h>

#include "stac_app.h"
#include "veml_model.h"

#ifndef STAC_BUILD_ID
#define STAC_BUILD_ID "native"
#endif

_Static_assert(STAC_SIM_WINDOW_BITS == VEML_MODEL_WINDOW_BITS,
               "a plan entry's CONF bits are the ones the model compares");
_Static_assert(STAC_SIM_I2C_OK == VEML_MODEL_OK && STAC_SIM_I2C_NACK == VEML_MODEL_NACK &&
                   STAC_SIM_I2C_BUS_ERROR == VEML_MODEL_BUS_ERROR,
               "model results are I2C results");

#define SENSORS 3u
#define STORE_PATH_MAX 4096u

_Static_assert(STAC_SIM_STORE_CAPACITY % STAC_FLASH_WORD == 0u, "the store holds whole words");

struct stac_sim {
    stac_app_t app;
    stac_sim_callbacks_t cb;
    uint32_t now;
    uint64_t now64; /* unwrapped device clock */
    /* Sensor models (stac_sim_init_models) and the plan of windows computed ahead. */
    uint32_t models_on;
    stac_sim_window_fn window;
    veml_model_t models[SENSORS];
    uint32_t plan_n;
    uint32_t plan_next[SENSORS];
    uint32_t plan_evaluated;
    stac_sim_window_t plan[STAC_SIM_PLAN_MAX];
    uint8_t uid[STAC_UID_SIZE];
    uint32_t rx_len; /* bytes waiting in rx; consumed from rx_pos */
    uint32_t rx_pos;
    uint8_t rx[STAC_SIM_RX_CAPACITY];
    /* Model store: the flash region, mirrored to store_path when one is set. */
    uint32_t flash_fail_in; /* operations until the injected fault (0: none) */
    char store_path[STORE_PATH_MAX];
    _Alignas(8) uint8_t store[STAC_SIM_STORE_CAPACITY];
    /* The modelled decoding time (hal_clock): the clock reads no earlier than busy_until. */
    uint32_t decodes_seen;
    uint32_t busy_until;
    bool busy;
    /* Protocol 1.4: what the simulated port reports at boot, a DEBUG_FAULT waiting to reset
     * the device after this step, and the ROM bootloader entered (the device is silent). */
    stac_boot_t boot;
    uint8_t fault_pending; /* 0 none, else 1 + STAC_FAULT_* kind */
    uint8_t in_bootloader;
    uint8_t abnormal; /* abnormal resets in a row (survives the simulated resets) */
};

/* The simulated MCU's decoding time. A host runs a decode in microseconds, a Cortex-M4F at
 * 96 MHz in ~10-15 ms for a paper-size model, and that time is what competes with the
 * sensors' integration, so the simulated device charges it to its clock: cycles per
 * multiply-add of the network's linear layers, every other part of a decode included, from
 * the cycle model of tools/bench/ondevice.py for the paper's ResMLP 128x3 (104,448 MACs:
 * 937k / 1421k / 1121k cycles a sample for float32 / float16 / int8, tools/bench/MEASUREMENTS.md).
 * A model, not a measurement: the simulated device reports no cycle counter (STATUS
 * cycle_hz 0), only ESTIMATE.decode_us and the timeline show this time. */
#define SIM_CPU_HZ 96000000u
static const uint32_t k_cycles_per_mac_x100[3] = {897u, 1360u, 1073u}; /* f32, f16, i8 */

static uint32_t modelled_decode_us(const stac_model_t *m) {
    uint64_t macs = 0u;
    for (uint16_t i = 0u; i < m->n_layers; i++) {
        macs += (uint64_t)m->layers[i].n_in * m->layers[i].n_out;
    }
    const uint32_t per_mac = k_cycles_per_mac_x100[m->weight_format < 3u ? m->weight_format : 0u];
    return (uint32_t)(macs * per_mac / (SIM_CPU_HZ / 10000u));
}

static uint32_t hal_clock(void *ctx) {
    stac_sim_t *sim = (stac_sim_t *)ctx;
    const uint32_t base = sim->cb.clock_us != NULL ? sim->cb.clock_us(sim->cb.user) : sim->now;
    /* Each decode since the last reading keeps the modelled CPU busy for its time, from when
     * it started (the clock cannot see inside it: the reading after it is the first). */
    const uint32_t decodes = sim->app.acq.decodes;
    const stac_model_t *m = stac_store_model(&sim->app.store);
    if (decodes != sim->decodes_seen && m != NULL) {
        const uint32_t start = sim->busy && stac_before(base, sim->busy_until) ? sim->busy_until
                                                                              : base;
        sim->busy_until = start + (decodes - sim->decodes_seen) * modelled_decode_us(m);
        sim->busy = true;
    }
    sim->decodes_seen = decodes;
    if (sim->busy && stac_before(base, sim->busy_until)) {
        return sim->busy_until;
    }
    sim->busy = false;
    return base;
}

/* A 32-bit time within the current step as 64-bit (never before the step's time). */
static uint64_t to64(const stac_sim_t *sim, uint32_t t32) {
    return sim->now64 + (uint64_t)((uint32_t)(t32 - (uint32_t)sim->now64) % 0x80000000u);
}

/* Window counts for a model: from the plan when it holds the entry this sensor is due to read,
 * else from the caller. */
static int32_t model_window(void *ctx, uint8_t index, uint64_t t0_us, uint64_t t1_us,
                            uint16_t conf, uint16_t counts[VEML_MODEL_CHANNELS],
                            uint8_t *saturated) {
    stac_sim_t *sim = (stac_sim_t *)ctx;
    const uint32_t j = sim->plan_next[index];
    if (j < sim->plan_n && j <= sim->plan_evaluated &&
        sim->plan_evaluated - j <= STAC_SIM_SHARED_WINDOWS) {
        const stac_sim_window_t *w = &sim->plan[j];
        if (w->t0_us == t0_us && w->t1_us == t1_us &&
            w->conf == (uint16_t)(conf & VEML_MODEL_WINDOW_BITS)) {
            memcpy(counts, w->counts[index], sizeof w->counts[index]);
            *saturated = w->saturated[index];
            sim->plan_next[index] = j + 1u;
            if (j == sim->plan_evaluated) {
                sim->plan_evaluated++;
            }
            return 0;
        }
    }
    return sim->window(sim->cb.user, index, t0_us, t1_us, conf, counts, saturated);
}

static int32_t hal_i2c(void *ctx, uint8_t bus, uint8_t addr7, const uint8_t *wr, uint32_t wr_len,
                       uint8_t *rd, uint32_t rd_len, uint32_t timeout_us) {
    stac_sim_t *sim = (stac_sim_t *)ctx;
    if (rd_len > 0u) {
        memset(rd, 0, rd_len); /* a callback that fails half-way leaves no stale bytes */
    }
    if (sim->models_on != 0u) {
        if (bus >= SENSORS || addr7 != 0x10u) {
            return STAC_SIM_I2C_NACK;
        }
        return veml_model_transfer(&sim->models[bus], to64(sim, hal_clock(sim)), wr, wr_len, rd,
                                   rd_len);
    }
    return sim->cb.i2c_transfer(sim->cb.user, hal_clock(sim), bus, addr7, wr, wr_len, rd, rd_len,
                                timeout_us);
}

static void hal_pwm(void *ctx, uint8_t led, uint8_t colour, uint16_t duty) {
    stac_sim_t *sim = (stac_sim_t *)ctx;
    sim->plan_n = 0u; /* windows computed ahead assumed the LEDs as they were */
    sim->cb.pwm_set(sim->cb.user, hal_clock(sim), led, colour, duty);
}

static uint32_t hal_write(void *ctx, const uint8_t *data, uint32_t len) {
    stac_sim_t *sim = (stac_sim_t *)ctx;
    return sim->cb.link_tx(sim->cb.user, hal_clock(sim), data, len);
}

static uint32_t hal_read(void *ctx, uint8_t *buf, uint32_t cap) {
    stac_sim_t *sim = (stac_sim_t *)ctx;
    uint32_t n = sim->rx_len - sim->rx_pos;
    if (n > cap) {
        n = cap;
    }
    memcpy(buf, sim->rx + sim->rx_pos, n);
    sim->rx_pos += n;
    if (sim->rx_pos == sim->rx_len) {
        sim->rx_pos = 0u;
        sim->rx_len = 0u;
    }
    return n;
}

static void hal_uid(void *ctx, uint8_t uid[STAC_UID_SIZE]) {
    const stac_sim_t *sim = (const stac_sim_t *)ctx;
    memcpy(uid, sim->uid, STAC_UID_SIZE);
}

/* Write store bytes [offset, offset + len) through to the file, if there is one. */
static int32_t store_write_through(const stac_sim_t *sim, uint32_t offset, uint32_t len) {
    if (sim->store_path[0] == '\0') {
        return STAC_FLASH_OK;
    }
    FILE *f = fopen(sim->store_path, "r+b");
    if (f == NULL) {
        return STAC_FLASH_FAILED;
    }
    const int ok = fseek(f, (long)offset, SEEK_SET) == 0 &&
                   fwrite(sim->store + offset, 1u, len, f) == len;
    return (fclose(f) == 0 && ok) ? STAC_FLASH_OK : STAC_FLASH_FAILED;
}

/* One flash operation: true when the injected fault makes it fail. */
static int flash_fault_now(stac_sim_t *sim) {
    if (sim->flash_fail_in == 0u) {
        return 0;
    }
    if (sim->flash_fail_in > 1u) {
        sim->flash_fail_in--;
        return 0;
    }
    return 1; /* stays at 1: every later operation fails too */
}

static uint32_t hal_store_capacity(void *ctx) {
    (void)ctx;
    return STAC_SIM_STORE_CAPACITY;
}

static const uint8_t *hal_store_data(void *ctx) {
    return ((const stac_sim_t *)ctx)->store;
}

static int store_range_ok(uint32_t offset, uint32_t len) {
    return offset % STAC_FLASH_WORD == 0u && len % STAC_FLASH_WORD == 0u &&
           offset <= STAC_SIM_STORE_CAPACITY && len <= STAC_SIM_STORE_CAPACITY - offset;
}

/* Erases exactly the range asked for (no sectors): the core must not count on anything else
 * being erased, which a port erasing whole sectors would hide. */
static int32_t hal_store_erase(void *ctx, uint32_t offset, uint32_t len) {
    stac_sim_t *sim = (stac_sim_t *)ctx;
    if (!store_range_ok(offset, len)) {
        return STAC_FLASH_BAD_ARG;
    }
    if (flash_fault_now(sim)) {
        return STAC_FLASH_FAILED;
    }
    memset(sim->store + offset, 0xFF, len);
    return store_write_through(sim, offset, len);
}

static int32_t hal_store_program(void *ctx, uint32_t offset, const uint8_t *data, uint32_t len) {
    stac_sim_t *sim = (stac_sim_t *)ctx;
    if (!store_range_ok(offset, len)) {
        return STAC_FLASH_BAD_ARG;
    }
    const int fail = flash_fault_now(sim);
    const uint32_t n = fail ? (len / STAC_FLASH_WORD / 2u) * STAC_FLASH_WORD : len;
    int32_t rc = STAC_FLASH_OK;
    for (uint32_t i = 0u; i < n; i++) {
        sim->store[offset + i] &= data[i]; /* NOR flash: programming only clears bits */
        if (sim->store[offset + i] != data[i]) {
            rc = STAC_FLASH_FAILED; /* the read-back a driver does after programming */
        }
    }
    const int32_t wt = store_write_through(sim, offset, n);
    if (fail) {
        return STAC_FLASH_FAILED;
    }
    return rc != STAC_FLASH_OK ? rc : wt;
}

uint32_t stac_sim_abi_version(void) {
    return STAC_SIM_ABI_VERSION;
}

uint32_t stac_sim_sizeof(void) {
    return (uint32_t)sizeof(stac_sim_t);
}

uint32_t stac_sim_default_capabilities(void) {
    return STAC_CAPS_CORE | STAC_CAPS_MODEL | STAC_CAP_SIMULATED;
}

/* Read the store from path, or create the file erased; 0 or -1. */
static int32_t load_store(stac_sim_t *sim, const char *path) {
    FILE *f = fopen(path, "rb");
    if (f == NULL) {
        f = fopen(path, "wb");
        if (f == NULL) {
            return -1;
        }
        const int ok = fwrite(sim->store, 1u, sizeof sim->store, f) == sizeof sim->store;
        return (fclose(f) == 0 && ok) ? 0 : -1;
    }
    const size_t got = fread(sim->store, 1u, sizeof sim->store, f);
    const int longer = fgetc(f) != EOF;
    const int failed = ferror(f);
    (void)fclose(f);
    return (got == sizeof sim->store && !longer && !failed) ? 0 : -1;
}

int32_t stac_sim_model_store(stac_sim_t *sim, const char *path) {
    if (sim == NULL || path == NULL || path[0] == '\0' || strlen(path) >= STORE_PATH_MAX) {
        return -1;
    }
    const int32_t rc = load_store(sim, path);
    if (rc == 0) {
        memcpy(sim->store_path, path, strlen(path) + 1u);
    } else {
        memset(sim->store, 0xFF, sizeof sim->store);
        sim->store_path[0] = '\0';
    }
    stac_store_boot(&sim->app.store, &sim->app.hal); /* as at power-up, with this flash */
    stac_state_estimator_reset(&sim->app);
    return rc;
}

void stac_sim_flash_fault(stac_sim_t *sim, uint32_t countdown) {
    sim->flash_fail_in = countdown;
}

/* ENTER_BOOTLOADER: the ACK is out; from now on the simulated MCU runs ST's ROM bootloader,
 * which speaks no SpectraTac protocol: the device neither reads nor answers. */
static void hal_enter_bootloader(void *ctx) {
    ((stac_sim_t *)ctx)->in_bootloader = 1u;
}

/* DEBUG_FAULT: the simulated device is a test image. The reset happens after the step that
 * sent the ACK, as the real one comes after the ACK has left. */
static void hal_debug_fault(void *ctx, uint8_t kind) {
    ((stac_sim_t *)ctx)->fault_pending = (uint8_t)(1u + kind);
}

/* Fault record of the simulated reset: a HardFault on an undefined instruction (stacked PC
 * and LR inside the image, CFSR UNDEFINSTR, HFSR FORCED), or a watchdog reset after a hang. */
#define SIM_FAULT_PC 0x08001A2Cu
#define SIM_FAULT_LR 0x08000F13u
#define SIM_CFSR_UNDEFINSTR (1u << 16)
#define SIM_HFSR_FORCED (1u << 30)

static void copy_text(char dst[STAC_TEXT_SIZE], const char *src);

/* Boot again after an injected fault: RAM (the app) starts over, flash (the store) stays. */
static void reboot_after_fault(stac_sim_t *sim) {
    const uint8_t kind = (uint8_t)(sim->fault_pending - 1u);
    sim->fault_pending = 0u;
    stac_boot_t *b = &sim->boot;
    const uint8_t bor = b->bor_level;
    memset(b, 0, sizeof *b);
    b->bor_level = bor;
    if (kind == STAC_FAULT_HARD) {
        b->reset_cause = STAC_RESET_PIN | STAC_RESET_SOFTWARE | STAC_RESET_FAULT;
        b->fault_pc = SIM_FAULT_PC;
        b->fault_lr = SIM_FAULT_LR;
        b->fault_xpsr = 0x01000003u; /* Thumb state, exception 3 (HardFault) */
        b->fault_cfsr = SIM_CFSR_UNDEFINSTR;
        b->fault_hfsr = SIM_HFSR_FORCED;
    } else {
        b->reset_cause = STAC_RESET_PIN | STAC_RESET_IWDG;
    }
    sim->abnormal = sim->abnormal < 255u ? (uint8_t)(sim->abnormal + 1u) : 255u;
    b->abnormal_resets = sim->abnormal;
    b->safe_mode = sim->abnormal >= STAC_SAFE_MODE_AFTER ? 1u : 0u;
    stac_identity_t id = sim->app.id;
    id.boot = *b;
    const stac_hal_t hal = sim->app.hal;
    stac_app_init(&sim->app, &hal, &id, sim->now);
}

static void copy_text(char dst[STAC_TEXT_SIZE], const char *src) {
    memset(dst, 0, STAC_TEXT_SIZE);
    for (size_t i = 0u; i < STAC_TEXT_SIZE - 1u && src[i] != '\0'; i++) {
        dst[i] = src[i];
    }
}

static void init_app(stac_sim_t *sim, const char *board, uint32_t capabilities,
                     const uint8_t *uid, uint32_t baud, uint32_t now_us) {
    sim->now = now_us;
    sim->now64 = now_us;
    if (uid != NULL) {
        memcpy(sim->uid, uid, STAC_UID_SIZE);
    }
    stac_identity_t id;
    copy_text(id.board, board != NULL ? board : "native-sim");
    copy_text(id.build_id, STAC_BUILD_ID);
    id.capabilities = capabilities;
    id.baud = baud;
    /* A provisioned board after power-on: brown-out level 3, nothing abnormal. */
    memset(&sim->boot, 0, sizeof sim->boot);
    sim->boot.reset_cause = STAC_RESET_POWER | STAC_RESET_PIN;
    sim->boot.bor_level = STAC_BOR_LEVEL_FOR_FLASH;
    id.boot = sim->boot;
    const stac_hal_t hal = {
        .ctx = sim,
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
        .enter_bootloader = hal_enter_bootloader,
        .debug_fault = hal_debug_fault,
    };
    memset(sim->store, 0xFF, sizeof sim->store);
    stac_app_init(&sim->app, &hal, &id, now_us);
}

int32_t stac_sim_init(stac_sim_t *sim, const stac_sim_callbacks_t *callbacks, const char *board,
                      uint32_t capabilities, const uint8_t *uid, uint32_t baud, uint32_t now_us) {
    if (sim == NULL || callbacks == NULL || callbacks->i2c_transfer == NULL ||
        callbacks->pwm_set == NULL || callbacks->link_tx == NULL) {
        return -1;
    }
    memset(sim, 0, sizeof *sim);
    sim->cb = *callbacks;
    init_app(sim, board, capabilities, uid, baud, now_us);
    return 0;
}

int32_t stac_sim_init_models(stac_sim_t *sim, const stac_sim_callbacks_t *callbacks,
                             stac_sim_window_fn window, uint32_t present_mask, const char *board,
                             uint32_t capabilities, const uint8_t *uid, uint32_t baud,
                             uint32_t now_us) {
    if (sim == NULL || callbacks == NULL || window == NULL || callbacks->pwm_set == NULL ||
        callbacks->link_tx == NULL) {
        return -1;
    }
    memset(sim, 0, sizeof *sim);
    sim->cb = *callbacks;
    sim->models_on = 1u;
    sim->window = window;
    for (uint32_t k = 0u; k < SENSORS; k++) {
        veml_model_init(&sim->models[k], (uint8_t)k, (uint8_t)((present_mask >> k) & 1u),
                        model_window, sim);
    }
    init_app(sim, board, capabilities, uid, baud, now_us);
    return 0;
}

void stac_sim_step64(stac_sim_t *sim, uint64_t now_us) {
    sim->now64 = now_us;
    sim->now = (uint32_t)now_us;
    if (sim->in_bootloader != 0u) {
        sim->rx_pos = sim->rx_len = 0u; /* the ROM bootloader does not read our frames */
        return;
    }
    stac_app_step(&sim->app, sim->now);
    if (sim->fault_pending != 0u) {
        reboot_after_fault(sim);
    }
}

uint32_t stac_sim_in_bootloader(const stac_sim_t *sim) {
    return sim->in_bootloader;
}

void stac_sim_step(stac_sim_t *sim, uint32_t now_us) {
    stac_sim_step64(sim, sim->now64 + (uint32_t)(now_us - (uint32_t)sim->now64));
}

uint64_t stac_sim_now64(const stac_sim_t *sim) {
    return sim->now64;
}

uint32_t stac_sim_run(stac_sim_t *sim, uint32_t max_steps) {
    uint32_t steps = 0u;
    while (steps < max_steps && sim->app.streaming && sim->rx_len == sim->rx_pos) {
        stac_sim_step64(sim, to64(sim, stac_sim_next_wake_us(sim)));
        steps++;
    }
    return steps;
}

uint32_t stac_sim_plan(stac_sim_t *sim, const stac_sim_window_t *windows, uint32_t n,
                       const uint32_t next[3], uint32_t evaluated) {
    if (sim->models_on == 0u) {
        return 0u;
    }
    if (n > STAC_SIM_PLAN_MAX) {
        n = STAC_SIM_PLAN_MAX;
    }
    if (n > 0u) {
        memcpy(sim->plan, windows, n * sizeof *windows);
    }
    sim->plan_n = n;
    for (uint32_t k = 0u; k < SENSORS; k++) {
        sim->plan_next[k] = next[k];
    }
    sim->plan_evaluated = evaluated;
    return n;
}

void stac_sim_plan_progress(const stac_sim_t *sim, uint32_t next[3], uint32_t *evaluated) {
    for (uint32_t k = 0u; k < SENSORS; k++) {
        next[k] = sim->plan_next[k];
    }
    *evaluated = sim->plan_evaluated;
}

int32_t stac_sim_sensor_transfer(stac_sim_t *sim, uint8_t bus, uint64_t now_us,
                                 const uint8_t *wr, uint32_t wr_len, uint8_t *rd,
                                 uint32_t rd_len) {
    if (sim->models_on == 0u || bus >= SENSORS) {
        return -1;
    }
    if (rd_len > 0u) {
        memset(rd, 0, rd_len);
    }
    return veml_model_transfer(&sim->models[bus], now_us, wr, wr_len, rd, rd_len);
}

uint32_t stac_sim_rx_feed(stac_sim_t *sim, const uint8_t *data, uint32_t len) {
    if (sim->rx_pos > 0u) {
        /* Compact so the whole capacity is available again. */
        memmove(sim->rx, sim->rx + sim->rx_pos, sim->rx_len - sim->rx_pos);
        sim->rx_len -= sim->rx_pos;
        sim->rx_pos = 0u;
    }
    uint32_t room = STAC_SIM_RX_CAPACITY - sim->rx_len;
    const uint32_t n = len < room ? len : room;
    if (n > 0u) {
        memcpy(sim->rx + sim->rx_len, data, n);
        sim->rx_len += n;
    }
    return n;
}

uint32_t stac_sim_next_wake_us(const stac_sim_t *sim) {
    if (sim->rx_len > sim->rx_pos) {
        return sim->now; /* fed bytes not yet read: a pass reads at most 512 of them */
    }
    return stac_app_next_wake_us(&sim->app);
}

uint32_t stac_sim_streaming(const stac_sim_t *sim) {
    return sim->app.streaming ? 1u : 0u;
}
