#include "stac_state.h"

#include <string.h>

/* LOG rate limit: a burst of LOG_BURST lines, then one more per LOG_REFILL_US. */
#define LOG_BURST 4u
#define LOG_REFILL_US 1000000u

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

void stac_state_init(stac_app_t *app, const stac_hal_t *hal, const stac_identity_t *id,
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
    if (app->id.boot.safe_mode == 0u) {
        stac_store_boot(&app->store, &app->hal);
    } /* safe mode: no model is opened; uploads and MODEL_CLEAR still work */
    stac_state_estimator_reset(app);
}

uint32_t stac_app_elapsed_us(const stac_app_t *app, uint32_t cycles0, uint32_t clock0) {
    if (app->hal.cycles != NULL && app->hal.cycle_hz != 0u) {
        const uint64_t c = (uint32_t)(app->hal.cycles(app->hal.ctx) - cycles0);
        return (uint32_t)(c * 1000000u / app->hal.cycle_hz);
    }
    return (uint32_t)(stac_app_clock(app) - clock0);
}

static char *put_text(char *p, const char *end, const char *t) {
    while (*t != '\0' && p < end) {
        *p++ = *t++;
    }
    return p;
}

static char *put_hex(char *p, const char *end, uint32_t v) {
    static const char digits[] = "0123456789ABCDEF";
    for (int shift = 28; shift >= 0 && p < end; shift -= 4) {
        *p++ = digits[(v >> (uint32_t)shift) & 0xFu];
    }
    return p;
}

void stac_app_boot_log(stac_app_t *app) {
    if (app->boot_logged) {
        return;
    }
    app->boot_logged = true;
    const stac_boot_t *b = &app->id.boot;
    if (b->note != NULL) {
        stac_app_log(app, STAC_LOG_WARN, b->note);
    }
    static const char *const names[8] = {"pin", "power", "brownout", "software",
                                         "iwdg", "wwdg", "lowpower", "fault"};
    const uint8_t clean = (uint8_t)(STAC_RESET_PIN | STAC_RESET_POWER);
    if ((b->reset_cause & (uint8_t)~clean) == 0u && b->safe_mode == 0u &&
        b->bor_level >= STAC_BOR_LEVEL_FOR_FLASH) {
        return;
    }
    char text[sizeof(((stac_log_t *)0)->text) + 1u] = {0};
    char *p = text;
    const char *end = text + sizeof text - 1u;
    p = put_text(p, end, "reset");
    for (uint32_t k = 0u; k < 8u; k++) {
        if ((b->reset_cause & (1u << k)) != 0u) {
            p = put_text(p, end, " ");
            p = put_text(p, end, names[k]);
        }
    }
    if ((b->reset_cause & STAC_RESET_FAULT) != 0u) {
        p = put_text(p, end, " pc=");
        p = put_hex(p, end, b->fault_pc);
        p = put_text(p, end, " cfsr=");
        p = put_hex(p, end, b->fault_cfsr);
    }
    if (b->safe_mode != 0u) {
        p = put_text(p, end, "; SAFE MODE: no model store");
    }
    if (b->bor_level < STAC_BOR_LEVEL_FOR_FLASH) {
        p = put_text(p, end, "; BOR<3: no uploads");
    }
    const bool bad = b->safe_mode != 0u ||
                     (b->reset_cause & (STAC_RESET_FAULT | STAC_RESET_IWDG | STAC_RESET_WWDG |
                                        STAC_RESET_BROWNOUT)) != 0u;
    stac_app_log(app, bad ? STAC_LOG_ERROR : STAC_LOG_WARN, text);
}

uint32_t stac_app_cycles(const stac_app_t *app) {
    return app->hal.cycles != NULL ? app->hal.cycles(app->hal.ctx) : 0u;
}

bool stac_state_estimating(const stac_app_t *app) {
    return (app->cfg.flags & STAC_CONFIG_ESTIMATE) != 0u && stac_store_model(&app->store) != NULL;
}

void stac_state_estimator_reset(stac_app_t *app) {
    app->acq.decode_pending = false; /* a waiting sample belongs to the session that ends */
    const stac_model_t *m = stac_store_model(&app->store);
    if (m != NULL) {
        stac_model_reset(m, &app->est);
    }
}

void stac_state_advance(stac_app_t *app, uint32_t now_us) {
    app->uptime_us += (uint32_t)(now_us - app->now);
    app->now = now_us;
    while (!stac_before(now_us, app->log_refill_at)) {
        if (app->log_tokens < LOG_BURST) {
            app->log_tokens++;
        }
        app->log_refill_at += LOG_REFILL_US;
    }
}

bool stac_app_send(stac_app_t *app, uint8_t type, const uint8_t *payload, size_t len) {
    const size_t n = stac_frame_encode(type, app->tx_seq++, payload, len, app->frame,
                                       sizeof app->frame);
    if (n > 0u && app->hal.link_write(app->hal.ctx, app->frame, (uint32_t)n) == (uint32_t)n) {
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
