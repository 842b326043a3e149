#include "stac_cmd.h"

#include <string.h>

#include "stac_acquisition.h"

#define NO_FIELD 255u
/* Indices of CONFIGURE's fields named by a NACK about estimates
 * (hardware/definitions/messages.toml). */
#define CONFIGURE_FLAGS_FIELD 4u
#define CONFIGURE_STEPS_FIELD 6u

static void send_ack(stac_app_t *app, const stac_frame_header_t *h) {
    const stac_ack_t ack = {.acked_type = h->type, .acked_seq = h->seq,
                            .config_id = app->latest_id};
    uint8_t p[STAC_ACK_SIZE];
    (void)stac_app_send(app, STAC_MSG_ACK, p, stac_ack_pack(&ack, p));
}

static void send_nack(stac_app_t *app, const stac_frame_header_t *h, uint16_t error,
                      uint8_t field) {
    const stac_nack_t nack = {.rejected_type = h->type, .rejected_seq = h->seq, .error = error,
                              .field_index = field};
    uint8_t p[STAC_NACK_SIZE];
    app->stats.command_errors++;
    (void)stac_app_send(app, STAC_MSG_NACK, p, stac_nack_pack(&nack, p));
}

static void send_info(stac_app_t *app) {
    stac_info_t m;
    memset(&m, 0, sizeof m);
    m.protocol_major = (uint8_t)STAC_PROTOCOL_MAJOR;
    m.protocol_minor = (uint8_t)STAC_PROTOCOL_MINOR;
    m.definition_hash = STAC_DEFINITION_HASH;
    m.firmware_version[0] = (uint8_t)STAC_FW_VERSION_MAJOR;
    m.firmware_version[1] = (uint8_t)STAC_FW_VERSION_MINOR;
    m.firmware_version[2] = (uint8_t)STAC_FW_VERSION_PATCH;
    memcpy(m.build_id, app->id.build_id, sizeof m.build_id);
    memcpy(m.device_uid, app->uid, sizeof m.device_uid);
    memcpy(m.board, app->id.board, sizeof m.board);
    m.sensor_count = (uint8_t)STAC_SENSORS;
    m.sensor_present = app->present;
    m.channels_per_sensor = (uint8_t)STAC_CHANNELS;
    m.capabilities = app->id.capabilities |
                     (app->hal.enter_bootloader != NULL ? STAC_CAP_BOOTLOADER : 0u) |
                     (app->hal.debug_fault != NULL ? STAC_CAP_DEBUG_FAULT : 0u);
    m.max_led_steps = (uint8_t)STAC_MAX_LED_STEPS;
    m.duty_full_scale = (uint16_t)STAC_DUTY_FULL_SCALE;
    m.integration_times_mask = 0x0Fu;
    m.max_frame = (uint16_t)STAC_MAX_FRAME;
    m.baud = app->id.baud;
    uint8_t p[STAC_INFO_SIZE];
    (void)stac_app_send(app, STAC_MSG_INFO, p, stac_info_pack(&m, p));
}

static void send_status(stac_app_t *app) {
    stac_status_t m;
    memset(&m, 0, sizeof m);
    m.uptime_ms = (uint32_t)(app->uptime_us / 1000u);
    m.device_time_us = stac_app_clock(app);
    m.streaming = app->streaming ? 1u : 0u;
    m.config_id = app->cfg_id;
    m.sensor_present = app->present;
    m.samples_taken = app->stats.samples_taken;
    m.frames_sent = app->stats.frames_sent;
    m.frames_dropped = app->stats.frames_dropped;
    for (uint32_t k = 0u; k < STAC_SENSORS; k++) {
        m.bus_errors[k] = app->stats.bus_errors[k];
        m.saturations[k] = app->stats.saturations[k];
    }
    m.rx_frames = app->stats.rx_frames;
    m.rx_errors = app->stats.rx_errors;
    m.command_errors = app->stats.command_errors;
    m.cycle_hz = app->hal.cycles != NULL ? app->hal.cycle_hz : 0u;
    m.acq_cycles_last = app->stats.acq_cycles_last;
    m.acq_cycles_max = app->stats.acq_cycles_max;
    m.decode_cycles_last = app->stats.decode_cycles_last;
    m.decode_cycles_max = app->stats.decode_cycles_max;
    const stac_boot_t *b = &app->id.boot;
    m.reset_cause = b->reset_cause;
    m.fault_pc = b->fault_pc;
    m.fault_lr = b->fault_lr;
    m.fault_xpsr = b->fault_xpsr;
    m.fault_cfsr = b->fault_cfsr;
    m.fault_hfsr = b->fault_hfsr;
    m.fault_mmfar = b->fault_mmfar;
    m.fault_bfar = b->fault_bfar;
    m.abnormal_resets = b->abnormal_resets;
    m.safe_mode = b->safe_mode;
    m.bor_level = b->bor_level;
    m.erase_us_last = app->stats.erase_us_last;
    m.erase_us_max = app->stats.erase_us_max;
    for (uint32_t k = 0u; k < STAC_SENSORS; k++) {
        m.trig_latency_us_last[k] = app->stats.trig_latency_us_last[k];
        m.trig_latency_us_max[k] = app->stats.trig_latency_us_max[k];
    }
    uint8_t p[STAC_STATUS_SIZE];
    (void)stac_app_send(app, STAC_MSG_STATUS, p, stac_status_pack(&m, p));
}

static void send_config(stac_app_t *app) {
    const stac_configure_t *c = &app->cfg;
    stac_config_t m;
    m.config_id = app->cfg_id;
    m.integration_ms = c->integration_ms;
    m.gain = c->gain;
    m.digital_gain = c->digital_gain;
    m.sensitivity = c->sensitivity;
    m.flags = c->flags;
    m.led_settle_us = c->led_settle_us;
    m.led_step_count = c->led_step_count;
    memcpy(m.led_duty, c->led_duty, sizeof m.led_duty);
    uint8_t p[STAC_CONFIG_SIZE];
    (void)stac_app_send(app, STAC_MSG_CONFIG, p, stac_config_pack(&m, p));
}

/* Estimates need a model, and one trained for the LED step count asked for. */
static uint16_t check_estimate(const stac_app_t *app, const stac_configure_t *c, uint8_t *field) {
    if ((c->flags & STAC_CONFIG_ESTIMATE) == 0u) {
        return STAC_OK;
    }
    const stac_model_t *m = stac_store_model(&app->store);
    if (m == NULL) {
        *field = CONFIGURE_FLAGS_FIELD;
        return STAC_NO_MODEL;
    }
    if (m->steps != c->led_step_count) {
        *field = CONFIGURE_STEPS_FIELD;
        return STAC_MODEL_MISMATCH;
    }
    return STAC_OK;
}

static void handle_configure(stac_app_t *app, const stac_frame_header_t *h, const uint8_t *payload,
                             size_t len) {
    stac_configure_t c;
    stac_configure_unpack(&c, payload, len);
    uint8_t field = NO_FIELD;
    uint16_t err = stac_configure_validate(&c, &field);
    if (err == STAC_OK) {
        err = check_estimate(app, &c, &field);
    }
    if (err != STAC_OK) {
        send_nack(app, h, err, field);
        return;
    }
    app->pending = c;
    app->has_pending = true;
    app->latest_id++;
    if (!app->streaming && app->acq.state == STAC_ACQ_IDLE) {
        /* Nothing is integrating: the configuration is in force at once. */
        app->cfg = c;
        app->cfg_id = app->latest_id;
        app->has_pending = false;
        app->acq.step = 0u;
        stac_state_estimator_reset(app);
    }
    send_ack(app, h);
    if ((c.flags & STAC_CONFIG_STREAM) != 0u) {
        stac_acquisition_start(app);
    }
}

static void handle_time_sync(stac_app_t *app, const uint8_t *payload, size_t len) {
    const uint32_t rx_us = stac_app_clock(app);
    stac_time_sync_request_t req;
    stac_time_sync_request_unpack(&req, payload, len);
    stac_time_sync_reply_t rep = {.exchange_id = req.exchange_id,
                                  .host_time_ns = req.host_time_ns,
                                  .device_rx_us = rx_us,
                                  .device_tx_us = 0u};
    uint8_t p[STAC_TIME_SYNC_REPLY_SIZE];
    rep.device_tx_us = stac_app_clock(app); /* taken last: only framing separates it from tx */
    (void)stac_app_send(app, STAC_MSG_TIME_SYNC_REPLY, p, stac_time_sync_reply_pack(&rep, p));
}

static void send_model_info(stac_app_t *app) {
    const stac_model_store_t *st = &app->store;
    stac_model_info_t m;
    memset(&m, 0, sizeof m);
    m.present = st->present;
    m.capacity = stac_store_capacity(&app->hal);
    m.max_inputs = (uint16_t)STAC_MODEL_MAX_INPUTS;
    m.max_hidden = (uint16_t)STAC_MODEL_MAX_HIDDEN;
    const stac_model_t *model = stac_store_model(st);
    if (model != NULL) {
        m.model_id = st->model_id;
        m.size = st->size;
        m.crc = st->crc;
        m.weight_format = model->weight_format;
        m.led_steps = model->steps;
        m.n_inputs = model->n_in;
        m.image_crc = model->crc; /* the image's own trailing CRC: it tells models apart */
    }
    uint8_t p[STAC_MODEL_INFO_SIZE];
    (void)stac_app_send(app, STAC_MSG_MODEL_INFO, p, stac_model_info_pack(&m, p));
}

/* MODEL_BEGIN / CHUNK / COMMIT / CLEAR: the store's answer, ACK or NACK. The session of the
 * model in use starts over whenever that model may have changed. */
static void handle_model(stac_app_t *app, const stac_frame_header_t *h, const uint8_t *payload,
                         size_t len) {
    uint16_t err = STAC_OK;
    uint8_t field = NO_FIELD;
    const struct {
        uint8_t present;
        uint32_t model_id, crc, size;
    } was = {app->store.present, app->store.model_id, app->store.crc, app->store.size};
    const uint32_t cycles0 = stac_app_cycles(app);
    const uint32_t clock0 = stac_app_clock(app);
    bool erased = false;
    switch (h->type) {
    case STAC_MSG_MODEL_BEGIN: {
        stac_model_begin_t m;
        stac_model_begin_unpack(&m, payload, len);
        if (app->id.boot.bor_level < STAC_BOR_LEVEL_FOR_FLASH) {
            err = STAC_BOR_TOO_LOW; /* refused before anything changes, like every refusal */
            break;
        }
        err = stac_store_begin(&app->store, &app->hal, m.model_id, m.size, m.crc);
        erased = err == STAC_OK || err == STAC_FLASH_ERROR;
        break;
    }
    case STAC_MSG_MODEL_CHUNK: {
        stac_model_chunk_t m;
        stac_model_chunk_unpack(&m, payload, len);
        err = stac_model_chunk_validate(&m, &field);
        if (err == STAC_OK) {
            err = stac_store_chunk(&app->store, &app->hal, m.offset, m.data, m.length);
        } else {
            stac_store_end_upload(&app->store); /* any refused chunk ends the upload */
        }
        break;
    }
    case STAC_MSG_MODEL_COMMIT: {
        stac_model_commit_t m;
        stac_model_commit_unpack(&m, payload, len);
        err = stac_store_commit(&app->store, &app->hal, m.model_id);
        break;
    }
    default:
        err = stac_store_clear(&app->store, &app->hal);
        erased = true;
        break;
    }
    if (erased) { /* the erase stalls the core: timed by the cycle counter, not by passes */
        const uint32_t us = stac_app_elapsed_us(app, cycles0, clock0);
        app->stats.erase_us_last = us;
        if (us > app->stats.erase_us_max) {
            app->stats.erase_us_max = us;
        }
    }
    /* The session starts over whenever the model in use may have changed (a refused command
     * that changed nothing leaves it running). */
    const stac_model_store_t *st = &app->store;
    if (h->type != STAC_MSG_MODEL_CHUNK &&
        (err == STAC_OK || st->present != was.present || st->model_id != was.model_id ||
         st->crc != was.crc || st->size != was.size)) {
        stac_state_estimator_reset(app);
    }
    if (err != STAC_OK) {
        send_nack(app, h, err, field);
    } else {
        send_ack(app, h);
    }
}

/* DEBUG_FAULT: only a test image has the hook; the ACK goes out before the fault. */
static void handle_debug_fault(stac_app_t *app, const stac_frame_header_t *h,
                               const uint8_t *payload, size_t len) {
    if (app->hal.debug_fault == NULL) {
        send_nack(app, h, STAC_NOT_A_TEST_IMAGE, NO_FIELD);
        return;
    }
    stac_debug_fault_t m;
    stac_debug_fault_unpack(&m, payload, len);
    uint8_t field = NO_FIELD;
    const uint16_t err = stac_debug_fault_validate(&m, &field);
    if (err != STAC_OK) {
        send_nack(app, h, err, field);
        return;
    }
    send_ack(app, h);
    app->hal.debug_fault(app->hal.ctx, m.kind);
}

static void handle_enter_bootloader(stac_app_t *app, const stac_frame_header_t *h) {
    if (app->hal.enter_bootloader == NULL) {
        send_nack(app, h, STAC_UNKNOWN_TYPE, NO_FIELD);
        return;
    }
    stac_acquisition_stop(app);
    stac_leds_off(&app->leds, &app->hal);
    send_ack(app, h);
    app->hal.enter_bootloader(app->hal.ctx);
}

static void reset_stats(stac_app_t *app) {
    memset(&app->stats, 0, sizeof app->stats);
}

void stac_cmd_handle(stac_app_t *app, const uint8_t *encoded, size_t len) {
    uint8_t raw[STAC_MAX_DECODED];
    stac_frame_header_t h;
    const uint8_t *payload = (const uint8_t *)0;
    size_t plen = 0u;
    if (stac_frame_decode(encoded, len, raw, &h, &payload, &plen) != STAC_FRAME_OK) {
        app->stats.rx_errors++;
        return;
    }
    app->stats.rx_frames++;
    stac_app_boot_log(app); /* a host is there now: say once how the device came up */
    if (h.major != STAC_PROTOCOL_MAJOR) {
        send_nack(app, &h, STAC_VERSION_MISMATCH, NO_FIELD);
        return;
    }
    if ((h.type & 0x80u) != 0u) {
        send_nack(app, &h, STAC_WRONG_DIRECTION, NO_FIELD);
        return;
    }
    if (stac_payload_size(h.type) < 0) {
        send_nack(app, &h, STAC_UNKNOWN_TYPE, NO_FIELD);
        return;
    }
    if (plen > STAC_MAX_PAYLOAD || plen < (size_t)stac_payload_min_size(h.type, h.minor)) {
        /* Too long, or without fields its sender's version has: never zero-filled. */
        send_nack(app, &h, STAC_MALFORMED, NO_FIELD);
        return;
    }
    /* Payload bytes beyond what this version knows are ignored; fields newer than the
     * sender's minor version read as zero (the generated unpack functions do both). */
    switch (h.type) {
    case STAC_MSG_GET_INFO: send_info(app); break;
    case STAC_MSG_CONFIGURE: handle_configure(app, &h, payload, plen); break;
    case STAC_MSG_START:
        stac_acquisition_start(app);
        send_ack(app, &h);
        break;
    case STAC_MSG_STOP: /* idempotent: a host resends a STOP whose ACK it missed */
        stac_acquisition_stop(app);
        send_ack(app, &h);
        break;
    case STAC_MSG_TIME_SYNC_REQUEST: handle_time_sync(app, payload, plen); break;
    case STAC_MSG_GET_STATUS: send_status(app); break;
    case STAC_MSG_GET_CONFIG: send_config(app); break;
    case STAC_MSG_RESET_STATS:
        reset_stats(app);
        send_ack(app, &h);
        break;
    case STAC_MSG_MODEL_BEGIN:
    case STAC_MSG_MODEL_CHUNK:
    case STAC_MSG_MODEL_COMMIT:
    case STAC_MSG_MODEL_CLEAR: handle_model(app, &h, payload, plen); break;
    case STAC_MSG_GET_MODEL: send_model_info(app); break;
    case STAC_MSG_TARE: /* the model's baseline takes the next sample as its zero */
        if (stac_store_model(&app->store) == NULL) {
            send_nack(app, &h, STAC_NO_MODEL, NO_FIELD);
        } else {
            stac_model_tare(&app->est);
            send_ack(app, &h);
        }
        break;
    case STAC_MSG_ENTER_BOOTLOADER: handle_enter_bootloader(app, &h); break;
    case STAC_MSG_DEBUG_FAULT: handle_debug_fault(app, &h, payload, plen); break;
    default:
        /* A host-to-device type in the generated table that this firmware does not serve. */
        send_nack(app, &h, STAC_UNKNOWN_TYPE, NO_FIELD);
        break;
    }
}
