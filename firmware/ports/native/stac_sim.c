/* Native port: adapts caller-supplied callbacks to the core's HAL, one instance per device. */
#include "stac_sim.h"

#include <string.h>

#include "stac_app.h"

#ifndef STAC_BUILD_ID
#define STAC_BUILD_ID "native"
#endif

struct stac_sim {
    stac_app_t app;
    stac_sim_callbacks_t cb;
    uint32_t now;
    uint8_t uid[STAC_UID_SIZE];
    uint32_t rx_len; /* bytes waiting in rx; consumed from rx_pos */
    uint32_t rx_pos;
    uint8_t rx[STAC_SIM_RX_CAPACITY];
};

static uint32_t hal_clock(void *ctx) {
    const stac_sim_t *sim = (const stac_sim_t *)ctx;
    return sim->cb.clock_us != NULL ? sim->cb.clock_us(sim->cb.user) : sim->now;
}

static int32_t hal_i2c(void *ctx, uint8_t bus, uint8_t addr7, const uint8_t *wr, uint32_t wr_len,
                       uint8_t *rd, uint32_t rd_len, uint32_t timeout_us) {
    stac_sim_t *sim = (stac_sim_t *)ctx;
    if (rd_len > 0u) {
        memset(rd, 0, rd_len); /* a callback that fails half-way leaves no stale bytes */
    }
    return sim->cb.i2c_transfer(sim->cb.user, hal_clock(sim), bus, addr7, wr, wr_len, rd, rd_len,
                                timeout_us);
}

static void hal_pwm(void *ctx, uint8_t led, uint8_t colour, uint16_t duty) {
    stac_sim_t *sim = (stac_sim_t *)ctx;
    sim->cb.pwm_set(sim->cb.user, hal_clock(sim), led, colour, duty);
}

static uint32_t hal_write(void *ctx, const uint8_t *data, uint32_t len) {
    stac_sim_t *sim = (stac_sim_t *)ctx;
    return sim->cb.uart_tx(sim->cb.user, hal_clock(sim), data, len);
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

uint32_t stac_sim_abi_version(void) {
    return STAC_SIM_ABI_VERSION;
}

uint32_t stac_sim_sizeof(void) {
    return (uint32_t)sizeof(stac_sim_t);
}

uint32_t stac_sim_default_capabilities(void) {
    return STAC_CAPS_CORE | STAC_CAP_SIMULATED;
}

static void copy_text(char dst[STAC_TEXT_SIZE], const char *src) {
    memset(dst, 0, STAC_TEXT_SIZE);
    for (size_t i = 0u; i < STAC_TEXT_SIZE - 1u && src[i] != '\0'; i++) {
        dst[i] = src[i];
    }
}

int32_t stac_sim_init(stac_sim_t *sim, const stac_sim_callbacks_t *callbacks, const char *board,
                      uint32_t capabilities, const uint8_t *uid, uint32_t baud, uint32_t now_us) {
    if (sim == NULL || callbacks == NULL || callbacks->i2c_transfer == NULL ||
        callbacks->pwm_set == NULL || callbacks->uart_tx == NULL) {
        return -1;
    }
    memset(sim, 0, sizeof *sim);
    sim->cb = *callbacks;
    sim->now = now_us;
    if (uid != NULL) {
        memcpy(sim->uid, uid, STAC_UID_SIZE);
    }
    stac_identity_t id;
    copy_text(id.board, board != NULL ? board : "native-sim");
    copy_text(id.build_id, STAC_BUILD_ID);
    id.capabilities = capabilities;
    id.baud = baud;
    const stac_hal_t hal = {
        .ctx = sim,
        .i2c_transfer = hal_i2c,
        .pwm_set = hal_pwm,
        .uart_write = hal_write,
        .uart_read = hal_read,
        .clock_us = hal_clock,
        .unique_id = hal_uid,
    };
    stac_app_init(&sim->app, &hal, &id, now_us);
    return 0;
}

void stac_sim_step(stac_sim_t *sim, uint32_t now_us) {
    sim->now = now_us;
    stac_app_step(&sim->app, now_us);
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
