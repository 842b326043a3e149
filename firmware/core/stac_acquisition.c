#include "stac_acquisition.h"

#include <string.h>

#include "veml3328.h"

static uint32_t integration_us(const stac_configure_t *cfg) {
    return (uint32_t)cfg->integration_ms * 1000u;
}

static veml3328_settings_t sensor_settings(const stac_configure_t *cfg) {
    veml3328_settings_t s;
    const int32_t it = veml3328_it_code(cfg->integration_ms);
    s.it_code = (uint8_t)(it < 0 ? 0 : it); /* cfg was validated; 50 ms is the safe fallback */
    s.gain = cfg->gain;
    s.dg = cfg->digital_gain;
    s.sens_low = cfg->sensitivity;
    return s;
}

static void max_into(uint32_t *max, uint32_t v) {
    if (v > *max) {
        *max = v;
    }
}

static const char *i2c_reason(int32_t rc) {
    switch (rc) {
    case STAC_I2C_NACK: return "no acknowledge";
    case STAC_I2C_TIMEOUT: return "bus timeout";
    case VEML3328_WRONG_ID: return "wrong device id";
    default: return "bus error";
    }
}

/* Text for a LOG line: "sensor <k> <what>". Built by hand to stay printf-free on the MCU. */
static void log_sensor(stac_app_t *app, uint8_t level, uint32_t k, const char *what) {
    char text[STAC_LOG_SIZE];
    size_t n = 0u;
    static const char k_prefix[] = "sensor ";
    memcpy(text, k_prefix, sizeof k_prefix - 1u);
    n = sizeof k_prefix - 1u;
    text[n++] = (char)('0' + k);
    text[n++] = ' ';
    for (size_t i = 0u; what[i] != '\0' && n < 63u; i++) {
        text[n++] = what[i];
    }
    text[n] = '\0';
    stac_app_log(app, level, text);
}

static void sensor_failed(stac_app_t *app, uint32_t k, int32_t rc) {
    app->stats.bus_errors[k]++;
    app->acq.fault |= (uint8_t)(1u << k);
    app->acq.pending &= (uint8_t)~(1u << k);
    if ((app->lost & (1u << k)) == 0u) {
        app->lost |= (uint8_t)(1u << k);
        char what[40] = "lost: ";
        const char *reason = i2c_reason(rc);
        size_t n = 6u;
        for (size_t i = 0u; reason[i] != '\0' && n < sizeof what - 1u; i++) {
            what[n++] = reason[i];
        }
        what[n] = '\0';
        log_sensor(app, STAC_LOG_WARN, k, what);
    }
}

static void sensor_ok(stac_app_t *app, uint32_t k) {
    if ((app->lost & (1u << k)) != 0u) {
        app->lost &= (uint8_t)~(1u << k);
        log_sensor(app, STAC_LOG_INFO, k, "recovered");
    }
}

void stac_acquisition_probe(stac_app_t *app) {
    const veml3328_settings_t s = sensor_settings(&app->cfg);
    for (uint32_t k = 0u; k < STAC_SENSORS; k++) {
        const uint8_t bit = (uint8_t)(1u << k);
        int32_t rc = veml3328_probe(&app->hal, (uint8_t)k);
        if (rc == STAC_I2C_OK) {
            rc = veml3328_configure(&app->hal, (uint8_t)k, &s);
        }
        if (rc == STAC_I2C_OK) {
            app->present |= bit;
        } else {
            if ((app->present & bit) != 0u) {
                log_sensor(app, STAC_LOG_WARN, k, "absent");
            }
            app->present &= (uint8_t)~bit;
        }
    }
}

/* Decode the finished sample waiting for the model and send its ESTIMATE. */
static void estimate(stac_app_t *app) {
    stac_acq_t *acq = &app->acq;
    if (!acq->decode_pending || stac_store_model(&app->store) == NULL) {
        acq->decode_pending = false;
        return;
    }
    acq->decode_pending = false;
    const stac_sample_t *s = &acq->decode_sample;
    const uint32_t t0 = stac_app_clock(app);
    const uint32_t c0 = stac_app_cycles(app);
    stac_model_output_t out;
    const int ready = stac_model_push(&app->store.model, &app->est, s->led_step, s->counts,
                                      s->sensor_status, &out);
    const uint32_t cycles = stac_app_cycles(app) - c0;
    acq->decodes++;
    const uint32_t took = stac_app_clock(app) - t0;
    app->stats.decode_cycles_last = cycles;
    max_into(&app->stats.decode_cycles_max, cycles);
    if (ready != 1) {
        return;
    }
    stac_estimate_t e;
    memset(&e, 0, sizeof e);
    e.sample_seq = s->sample_seq;
    e.t_end_us = s->t_end_us;
    e.config_id = s->config_id;
    e.model_id = app->store.model_id;
    e.flags = out.flags;
    memcpy(e.force, out.force, sizeof e.force);
    memcpy(e.torque, out.torque, sizeof e.torque);
    e.region = out.region;
    e.region_prob = out.region_prob;
    e.decode_us = (uint16_t)(took > 0xFFFFu ? 0xFFFFu : took);
    uint8_t payload[STAC_ESTIMATE_SIZE];
    (void)stac_app_send(app, STAC_MSG_ESTIMATE, payload, stac_estimate_pack(&e, payload));
}

/* Apply an accepted configuration: only ever between cycles. */
static void apply_pending(stac_app_t *app) {
    if (!app->has_pending) {
        return;
    }
    estimate(app); /* the last sample of the old configuration, in the session it belongs to */
    app->cfg = app->pending;
    app->cfg_id = app->latest_id;
    app->has_pending = false;
    app->acq.step = 0u;
    stac_state_estimator_reset(app);
}

void stac_acquisition_start(stac_app_t *app) {
    if (app->streaming) {
        return;
    }
    /* A sensor plugged in (or powered) since boot is picked up here. */
    if (app->present != (uint8_t)((1u << STAC_SENSORS) - 1u)) {
        stac_acquisition_probe(app);
    }
    app->streaming = true;
    app->sample_seq = 0u;
    app->acq.step = 0u;
    app->acq.state = STAC_ACQ_IDLE;
    stac_state_estimator_reset(app);
}

void stac_acquisition_stop(stac_app_t *app) {
    estimate(app); /* every SAMPLE sent keeps its ESTIMATE, before STOP is answered */
    if (app->acq.state == STAC_ACQ_INTEGRATE && app->acq.pending != 0u) {
        /* The sensors are still integrating: do not retrigger them before they finish. */
        app->acq.busy = true;
    }
    app->streaming = false;
    app->acq.state = STAC_ACQ_IDLE;
    stac_leds_off(&app->leds, &app->hal);
}

static void begin_cycle(stac_app_t *app) {
    apply_pending(app);
    if (app->acq.step >= app->cfg.led_step_count) {
        app->acq.step = 0u;
    }
    const bool changed = stac_leds_apply(&app->leds, &app->hal,
                                         &app->cfg.led_duty[app->acq.step][0][0]);
    /* Settle from when the light actually changed, not from the start of the pass. */
    uint32_t at = stac_app_clock(app) + (changed ? (uint32_t)app->cfg.led_settle_us : 0u);
    if (app->acq.busy) {
        if (stac_before(at, app->acq.deadline)) {
            at = app->acq.deadline;
        }
        app->acq.busy = false;
    }
    app->acq.settle_until = at;
    app->acq.state = STAC_ACQ_SETTLE;
}

static void trigger(stac_app_t *app) {
    const uint32_t c0 = stac_app_cycles(app);
    const veml3328_settings_t s = sensor_settings(&app->cfg);
    stac_acq_t *acq = &app->acq;
    acq->t_start = stac_app_clock(app);
    acq->fault = 0u;
    acq->done = 0u;
    acq->pending = 0u;
    for (uint32_t k = 0u; k < STAC_SENSORS; k++) {
        if ((app->present & (1u << k)) == 0u) {
            continue;
        }
        acq->pending |= (uint8_t)(1u << k);
        const int32_t rc = veml3328_trigger(&app->hal, (uint8_t)k, &s);
        acq->trig_at[k] = stac_app_clock(app);
        if (rc != STAC_I2C_OK) {
            sensor_failed(app, k, rc);
        }
    }
    acq->trig_set = 0u;
    const uint32_t it = integration_us(&app->cfg);
    acq->poll_at = acq->t_start + it;
    acq->deadline = acq->t_start + it + STAC_STALE_MARGIN_US(it);
    acq->state = STAC_ACQ_INTEGRATE;
    acq->cycles = stac_app_cycles(app) - c0; /* a new window's account */
}

static void poll(stac_app_t *app) {
    const uint32_t c0 = stac_app_cycles(app);
    stac_acq_t *acq = &app->acq;
    for (uint32_t k = 0u; k < STAC_SENSORS; k++) {
        const uint8_t bit = (uint8_t)(1u << k);
        if ((acq->pending & bit) == 0u) {
            continue;
        }
        bool done = false;
        const int32_t rc = veml3328_poll_done(&app->hal, (uint8_t)k, &done);
        if (rc != STAC_I2C_OK) {
            sensor_failed(app, k, rc);
        } else if (done) {
            acq->pending &= (uint8_t)~bit;
            acq->done |= bit;
            acq->trig_set &= (uint8_t)~bit;
            const uint32_t latency = stac_app_clock(app) - acq->trig_at[k];
            app->stats.trig_latency_us_last[k] = latency;
            max_into(&app->stats.trig_latency_us_max[k], latency);
        } else {
            acq->trig_set |= bit;
        }
    }
    acq->cycles += stac_app_cycles(app) - c0;
}

/* Sensor k answered but still had TRIG set at the deadline. Whether the VEML3328 clears TRIG
 * itself is not settled by its datasheet (hardware/datasheet_facts.toml), and a sensor that
 * keeps it set must not go stale for ever: clear TRIG (so the next trigger is a fresh 0 -> 1
 * write), count it, and read the data registers, which hold a finished conversion by now (the
 * deadline is a quarter beyond the integration time). Counts that differ from the last reading
 * prove a new conversion, and from then on the sensor is read by time; until then identical
 * counts are no evidence (a sensor that never finishes, or one slower than the deadline) and
 * stay stale. Returns the sensor status; the counts go to c. */
static uint8_t read_trig_stuck(stac_app_t *app, uint32_t k, uint16_t c[STAC_CHANNELS]) {
    stac_acq_t *acq = &app->acq;
    const uint8_t bit = (uint8_t)(1u << k);
    const veml3328_settings_t settings = sensor_settings(&app->cfg);
    app->stats.trig_stuck[k]++;
    bool sat = false;
    int32_t rc = veml3328_configure(&app->hal, (uint8_t)k, &settings);
    if (rc == STAC_I2C_OK) {
        rc = veml3328_read_channels(&app->hal, (uint8_t)k, c, &sat);
    }
    if (rc != STAC_I2C_OK) {
        sensor_failed(app, k, rc);
        return STAC_SENSOR_BUS_FAULT;
    }
    if (memcmp(c, acq->last_counts[k], sizeof acq->last_counts[k]) != 0 &&
        (acq->trig_timed & bit) == 0u) {
        acq->trig_timed |= bit;
        log_sensor(app, STAC_LOG_WARN, k, "keeps TRIG set: read by time");
    } else if ((acq->trig_timed & bit) == 0u) {
        memcpy(c, acq->last_counts[k], sizeof acq->last_counts[k]);
        return STAC_SENSOR_STALE;
    }
    sensor_ok(app, k);
    memcpy(acq->last_counts[k], c, sizeof acq->last_counts[k]);
    if (sat) {
        app->stats.saturations[k]++;
        return STAC_SENSOR_SATURATED;
    }
    return 0u;
}

/* Read the finished sensors and hand the SAMPLE to the host link, all in this pass; a model
 * decodes it later in the pass, once the next integration is running. */
static void finish(stac_app_t *app) {
    const uint32_t c0 = stac_app_cycles(app);
    stac_acq_t *acq = &app->acq;
    stac_sample_t s;
    memset(&s, 0, sizeof s);
    for (uint32_t k = 0u; k < STAC_SENSORS; k++) {
        const uint8_t bit = (uint8_t)(1u << k);
        uint8_t st = 0u;
        if ((app->present & bit) == 0u) {
            st = STAC_SENSOR_ABSENT;
        } else if ((acq->done & bit) != 0u) {
            bool sat = false;
            uint16_t c[STAC_CHANNELS];
            const int32_t rc = veml3328_read_channels(&app->hal, (uint8_t)k, c, &sat);
            if (rc != STAC_I2C_OK) {
                sensor_failed(app, k, rc);
                st = STAC_SENSOR_BUS_FAULT;
            } else {
                sensor_ok(app, k);
                memcpy(acq->last_counts[k], c, sizeof c);
                memcpy(s.counts[k], c, sizeof c);
                if (sat) {
                    st = STAC_SENSOR_SATURATED;
                    app->stats.saturations[k]++;
                }
            }
        } else if ((acq->fault & bit) != 0u) {
            st = STAC_SENSOR_BUS_FAULT;
        } else if ((acq->trig_set & bit) != 0u) {
            uint16_t c[STAC_CHANNELS];
            st = read_trig_stuck(app, k, c);
            if (st != STAC_SENSOR_BUS_FAULT) {
                memcpy(s.counts[k], c, sizeof s.counts[k]);
            }
        } else {
            /* Answered, but did not finish in time: repeat its last good counts. */
            st = STAC_SENSOR_STALE;
            memcpy(s.counts[k], acq->last_counts[k], sizeof s.counts[k]);
        }
        s.sensor_status[k] = st;
    }
    s.sample_seq = app->sample_seq++;
    s.t_start_us = acq->t_start;
    s.t_end_us = stac_app_clock(app);
    s.led_step = acq->step;
    s.config_id = app->cfg_id;
    app->stats.samples_taken++;
    const bool estimating = stac_state_estimating(app);
    if (!estimating || (app->cfg.flags & STAC_CONFIG_ESTIMATE_ONLY) == 0u) {
        uint8_t payload[STAC_SAMPLE_SIZE];
        const size_t n = stac_sample_pack(&s, payload);
        (void)stac_app_send(app, STAC_MSG_SAMPLE, payload, n);
    }
    if (estimating) {
        estimate(app); /* never two waiting: a decode missed by a slow pass is done first */
        acq->decode_sample = s;
        acq->decode_pending = true;
    }
    acq->cycles += stac_app_cycles(app) - c0;
    app->stats.acq_cycles_last = acq->cycles;
    max_into(&app->stats.acq_cycles_max, acq->cycles);

    acq->pending = 0u;
    acq->step = (uint8_t)((acq->step + 1u) % app->cfg.led_step_count);
    acq->state = STAC_ACQ_IDLE;
}

static void advance(stac_app_t *app) {
    stac_acq_t *acq = &app->acq;
    /* At most one full cycle per pass: finish -> next cycle -> trigger. */
    for (uint32_t transitions = 0u; transitions < 4u; transitions++) {
        /* Bus transfers take time, so each decision reads the clock afresh. */
        const uint32_t now = stac_app_clock(app);
        switch (acq->state) {
        case STAC_ACQ_IDLE:
            if (!app->streaming) {
                apply_pending(app);
                return;
            }
            begin_cycle(app);
            break;
        case STAC_ACQ_SETTLE:
            if (stac_before(now, acq->settle_until)) {
                return;
            }
            trigger(app);
            break;
        case STAC_ACQ_INTEGRATE:
            if (stac_before(now, acq->poll_at)) {
                return;
            }
            poll(app);
            if (acq->pending != 0u && stac_before(stac_app_clock(app), acq->deadline)) {
                acq->poll_at = now + STAC_POLL_INTERVAL_US;
                return;
            }
            finish(app);
            break;
        default:
            acq->state = STAC_ACQ_IDLE;
            return;
        }
    }
}

void stac_acquisition_run(stac_app_t *app) {
    advance(app);
    /* Decode only once the next integration has been triggered (or none is coming): the
     * sensors integrate while the model runs, so a model costs the sample rate nothing as
     * long as a decode is shorter than an integration. Not during an LED settle, which
     * would delay the trigger. */
    if (app->acq.state != STAC_ACQ_SETTLE) {
        estimate(app);
    }
}

uint32_t stac_acquisition_next_wake(const stac_app_t *app, uint32_t idle_us) {
    switch (app->acq.state) {
    case STAC_ACQ_SETTLE: return app->acq.settle_until;
    case STAC_ACQ_INTEGRATE: return app->acq.poll_at;
    default: return app->streaming ? app->now : app->now + idle_us;
    }
}
