#include "stac_app.h"

#include <string.h>

#include "stac_cmd.h"
#include "stac_sched.h"

/* Bytes read from the UART per pass: bounds the pass time under a flood of input while
 * staying far above what a 921600 baud link delivers between passes. */
#define RX_BYTES_PER_PASS 512u
#define LOG_BURST 4u
#define LOG_REFILL_US 1000000u
#define IDLE_WAKE_US 10000u

void stac_default_config(stac_configure_t *cfg) {
    memset(cfg, 0, sizeof *cfg);
    cfg->integration_ms = 50u;
    cfg->gain = STAC_GAIN_X1;
    cfg->digital_gain = STAC_DG_X1;
    cfg->sensitivity = STAC_SENS_HIGH;
    cfg->flags = 0u;
    cfg->led_settle_us = 1000u;
    cfg->led_step_count = 1u;
    for (uint32_t l = 0u; l < STAC_LEDS; l++) {
        for (uint32_t c = 0u; c < STAC_COLOURS; c++) {
            cfg->led_duty[0][l][c] = 500u;
        }
    }
}

uint32_t stac_app_clock(const stac_app_t *app) {
    return app->hal.clock_us(app->hal.ctx);
}

void stac_app_init(stac_app_t *app, const stac_hal_t *hal, const stac_identity_t *id,
                   uint32_t now_us) {
    memset(app, 0, sizeof *app);
    app->hal = *hal;
    app->id = *id;
    app->hal.unique_id(app->hal.ctx, app->uid);
    app->now = now_us;
    stac_default_config(&app->cfg);
    app->pending = app->cfg;
    stac_leds_init(&app->leds);
    stac_rx_reset(&app->rx);
    app->log_tokens = LOG_BURST;
    app->log_refill_at = now_us + LOG_REFILL_US;
    stac_sched_probe(app);
    stac_leds_off(&app->leds, &app->hal);
}

bool stac_app_send(stac_app_t *app, uint8_t type, const uint8_t *payload, size_t len) {
    const size_t n = stac_frame_encode(type, app->tx_seq++, payload, len, app->frame,
                                       sizeof app->frame);
    if (n > 0u && app->hal.uart_write(app->hal.ctx, app->frame, (uint32_t)n) == (uint32_t)n) {
        app->stats.frames_sent++;
        return true;
    }
    app->stats.frames_dropped++;
    return false;
}

void stac_app_log(stac_app_t *app, uint8_t level, const char *text) {
    if (app->log_tokens == 0u) {
        return;
    }
    app->log_tokens--;
    stac_log_t m;
    memset(&m, 0, sizeof m);
    m.level = level;
    m.device_time_us = stac_app_clock(app);
    for (size_t i = 0u; i < sizeof m.text && text[i] != '\0'; i++) {
        m.text[i] = text[i];
    }
    uint8_t p[STAC_LOG_SIZE];
    (void)stac_app_send(app, STAC_MSG_LOG, p, stac_log_pack(&m, p));
}

static void advance_time(stac_app_t *app, uint32_t now_us) {
    app->uptime_us += (uint32_t)(now_us - app->now);
    app->now = now_us;
    while (!stac_before(now_us, app->log_refill_at)) {
        if (app->log_tokens < LOG_BURST) {
            app->log_tokens++;
        }
        app->log_refill_at += LOG_REFILL_US;
    }
}

static void receive(stac_app_t *app) {
    uint8_t chunk[64];
    uint32_t total = 0u;
    while (total < RX_BYTES_PER_PASS) {
        const uint32_t n = app->hal.uart_read(app->hal.ctx, chunk, sizeof chunk);
        if (n == 0u) {
            return;
        }
        total += n;
        for (uint32_t i = 0u; i < n && i < sizeof chunk; i++) {
            switch (stac_rx_push(&app->rx, chunk[i])) {
            case STAC_RX_FRAME: stac_cmd_handle(app, app->rx.buf, app->rx.len); break;
            case STAC_RX_OVERSIZE: app->stats.rx_errors++; break;
            default: break;
            }
        }
    }
}

void stac_app_step(stac_app_t *app, uint32_t now_us) {
    advance_time(app, now_us);
    receive(app);
    stac_sched_run(app);
}

uint32_t stac_app_next_wake_us(const stac_app_t *app) {
    return stac_sched_next_wake(app, IDLE_WAKE_US);
}
