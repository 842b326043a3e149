/* Command handling: answers, validation with specific NACK codes, bad input, statistics. */
#include <string.h>

#include "check.h"
#include "helpers.h"
#include "stac_crc32c.h"

static fake_board_t g_b;
static stac_app_t g_app;

static void boot(void) {
    fake_init(&g_b);
    fake_boot(&g_b, &g_app);
}

/* Run one pass and return the number of frames captured so far. */
static int pass(void) {
    g_b.pass++;
    stac_app_step(&g_app, g_b.now);
    g_b.now += 100u;
    return h_frames(&g_b);
}

static stac_nack_t last_nack(int n) {
    stac_nack_t m;
    memset(&m, 0, sizeof m);
    const fake_frame_t *f = fake_last(g_frames, n, STAC_MSG_NACK);
    if (f != NULL) {
        stac_nack_unpack(&m, f->payload, f->len);
    }
    return m;
}

TEST(cmd_get_info) {
    boot();
    h_send_empty(&g_b, STAC_MSG_GET_INFO, 0x1234);
    const int n = pass();
    CHECK_EQ(n, 1);
    CHECK_EQ(g_frames[0].h.type, STAC_MSG_INFO);
    CHECK_EQ(g_frames[0].h.seq, 0);
    CHECK_EQ(g_frames[0].len, STAC_INFO_SIZE);
    stac_info_t m;
    stac_info_unpack(&m, g_frames[0].payload, g_frames[0].len);
    CHECK_EQ(m.protocol_major, 1);
    CHECK_EQ(m.protocol_minor, STAC_PROTOCOL_MINOR);
    CHECK_EQ(m.definition_hash, STAC_DEFINITION_HASH);
    CHECK(strcmp(m.board, "fake-board") == 0);
    CHECK(strcmp(m.build_id, "test") == 0);
    CHECK_EQ(m.device_uid[0], 0xA0);
    CHECK_EQ(m.device_uid[11], 0xAB);
    CHECK_EQ(m.sensor_count, 3);
    CHECK_EQ(m.sensor_present, 7);
    CHECK_EQ(m.channels_per_sensor, 5);
    CHECK_EQ(m.capabilities, STAC_CAPS_CORE | STAC_CAPS_MODEL);
    CHECK_EQ(m.max_led_steps, 8);
    CHECK_EQ(m.duty_full_scale, 1000);
    CHECK_EQ(m.integration_times_mask, 0x0F);
    CHECK_EQ(m.max_frame, 256);
    CHECK_EQ(m.baud, 921600);
}

TEST(cmd_default_config) {
    boot();
    h_send_empty(&g_b, STAC_MSG_GET_CONFIG, 1);
    const int n = pass();
    stac_config_t c;
    stac_config_unpack(&c, g_frames[n - 1].payload, g_frames[n - 1].len);
    CHECK_EQ(c.config_id, 0);
    CHECK_EQ(c.integration_ms, 50);
    CHECK_EQ(c.gain, STAC_GAIN_X1);
    CHECK_EQ(c.digital_gain, STAC_DG_X1);
    CHECK_EQ(c.sensitivity, STAC_SENS_HIGH);
    CHECK_EQ(c.flags, 0);
    CHECK_EQ(c.led_settle_us, 1000);
    CHECK_EQ(c.led_step_count, 1);
    for (int l = 0; l < 3; l++) {
        for (int col = 0; col < 3; col++) {
            CHECK_EQ(c.led_duty[0][l][col], 500);
            CHECK_EQ(c.led_duty[1][l][col], 0);
        }
    }
}

typedef struct bad_case {
    void (*mutate)(stac_configure_t *c);
    uint16_t error;
    uint8_t field;
} bad_case_t;

static void bad_it(stac_configure_t *c) { c->integration_ms = 75; }
static void bad_gain(stac_configure_t *c) { c->gain = 4; }
static void bad_dg(stac_configure_t *c) { c->digital_gain = 3; }
static void bad_sens(stac_configure_t *c) { c->sensitivity = 2; }
static void bad_flags(stac_configure_t *c) { c->flags = 0x82; }
static void bad_settle(stac_configure_t *c) { c->led_settle_us = 10001; }
static void zero_steps(stac_configure_t *c) { c->led_step_count = 0; }
static void many_steps(stac_configure_t *c) { c->led_step_count = 9; }
static void bad_duty(stac_configure_t *c) { c->led_duty[0][2][1] = 1001; }
static void bad_unused_duty(stac_configure_t *c) { c->led_duty[7][0][0] = 4000; }

TEST(cmd_configure_rejections_name_the_field) {
    static const bad_case_t cases[] = {
        {bad_it, STAC_BAD_INTEGRATION_TIME, 0}, {bad_gain, STAC_BAD_GAIN, 1},
        {bad_dg, STAC_BAD_DIGITAL_GAIN, 2},     {bad_sens, STAC_BAD_SENSITIVITY, 3},
        {bad_flags, STAC_BAD_FLAGS, 4},         {bad_settle, STAC_BAD_SETTLE_TIME, 5},
        {zero_steps, STAC_BAD_STEP_COUNT, 6},   {many_steps, STAC_BAD_STEP_COUNT, 6},
        {bad_duty, STAC_DUTY_OUT_OF_RANGE, 7},  {bad_unused_duty, STAC_DUTY_OUT_OF_RANGE, 7},
    };
    boot();
    uint16_t seq = 100;
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        stac_configure_t c;
        stac_default_config(&c);
        cases[i].mutate(&c);
        h_send_configure(&g_b, &c, seq);
        const int n = pass();
        CHECK_EQ(g_frames[n - 1].h.type, STAC_MSG_NACK);
        const stac_nack_t m = last_nack(n);
        CHECK_EQ(m.rejected_type, STAC_MSG_CONFIGURE);
        CHECK_EQ(m.rejected_seq, seq);
        CHECK_EQ(m.error, cases[i].error);
        CHECK_EQ(m.field_index, cases[i].field);
        seq++;
    }
    /* Nothing changed. */
    CHECK_EQ(g_app.cfg_id, 0);
    CHECK_EQ(g_app.latest_id, 0);
    CHECK_EQ(g_app.cfg.integration_ms, 50);
    CHECK_EQ(g_app.stats.command_errors, 10);
}

TEST(cmd_configure_accepted_and_reported) {
    boot();
    stac_configure_t c;
    stac_default_config(&c);
    c.integration_ms = 400;
    c.gain = STAC_GAIN_X0_5;
    c.digital_gain = STAC_DG_X4;
    c.sensitivity = STAC_SENS_LOW;
    c.led_settle_us = 10000;
    c.led_step_count = 8;
    c.led_duty[7][2][2] = 1000;
    h_send_configure(&g_b, &c, 3);
    h_send_empty(&g_b, STAC_MSG_GET_CONFIG, 4);
    const int n = pass();
    CHECK_EQ(n, 2);
    stac_ack_t a;
    stac_ack_unpack(&a, g_frames[0].payload, g_frames[0].len);
    CHECK_EQ(g_frames[0].h.type, STAC_MSG_ACK);
    CHECK_EQ(a.acked_type, STAC_MSG_CONFIGURE);
    CHECK_EQ(a.acked_seq, 3);
    CHECK_EQ(a.config_id, 1);
    stac_config_t got;
    stac_config_unpack(&got, g_frames[1].payload, g_frames[1].len);
    CHECK_EQ(got.config_id, 1);
    CHECK_EQ(got.integration_ms, 400);
    CHECK_EQ(got.gain, STAC_GAIN_X0_5);
    CHECK_EQ(got.led_step_count, 8);
    CHECK_EQ(got.led_duty[7][2][2], 1000);
    CHECK(!g_app.streaming); /* no CONFIG_STREAM flag: still silent */
}

TEST(cmd_short_and_long_payloads) {
    boot();
    /* A CONFIGURE cut short of the 1.0 layout is malformed: never zero-filled. */
    uint8_t p[STAC_CONFIGURE_SIZE + 8];
    memset(p, 0, sizeof p);
    fake_send(&g_b, STAC_MSG_CONFIGURE, 1, p, 1);
    int n = pass();
    stac_nack_t m = last_nack(n);
    CHECK_EQ(m.error, STAC_MALFORMED);
    CHECK_EQ(m.rejected_seq, 1);
    /* A longer one (a future minor version) is accepted; the extra bytes are ignored. */
    stac_configure_t c;
    stac_default_config(&c);
    stac_configure_pack(&c, p);
    memset(p + STAC_CONFIGURE_SIZE, 0xEE, 8);
    fake_send(&g_b, STAC_MSG_CONFIGURE, 2, p, sizeof p);
    n = pass();
    CHECK_EQ(g_frames[n - 1].h.type, STAC_MSG_ACK);
    /* GET_INFO with a payload it does not need is still answered. */
    fake_send(&g_b, STAC_MSG_GET_INFO, 3, p, 4);
    n = pass();
    CHECK_EQ(g_frames[n - 1].h.type, STAC_MSG_INFO);
}

TEST(cmd_unknown_wrong_direction_version) {
    boot();
    h_send_empty(&g_b, 0x30, 11);
    int n = pass();
    stac_nack_t m = last_nack(n);
    CHECK_EQ(m.rejected_type, 0x30);
    CHECK_EQ(m.rejected_seq, 11);
    CHECK_EQ(m.error, STAC_UNKNOWN_TYPE);
    CHECK_EQ(m.field_index, 255);
    uint8_t sample[STAC_SAMPLE_SIZE] = {0};
    fake_send(&g_b, STAC_MSG_SAMPLE, 12, sample, sizeof sample);
    n = pass();
    m = last_nack(n);
    CHECK_EQ(m.rejected_type, STAC_MSG_SAMPLE);
    CHECK_EQ(m.error, STAC_WRONG_DIRECTION);
    uint8_t wire[STAC_MAX_FRAME];
    const size_t w = stac_frame_encode_version(2, 0, STAC_MSG_GET_INFO, 13, NULL, 0, wire,
                                               sizeof wire);
    fake_send_raw(&g_b, wire, w);
    n = pass();
    CHECK_EQ(g_frames[n - 1].h.major, 1); /* the NACK itself is in our version */
    m = last_nack(n);
    CHECK_EQ(m.rejected_type, STAC_MSG_GET_INFO);
    CHECK_EQ(m.rejected_seq, 13);
    CHECK_EQ(m.error, STAC_VERSION_MISMATCH);
    /* A newer minor version of a known command is served. */
    const size_t w2 = stac_frame_encode_version(1, 7, STAC_MSG_GET_INFO, 14, NULL, 0, wire,
                                                sizeof wire);
    fake_send_raw(&g_b, wire, w2);
    n = pass();
    CHECK_EQ(g_frames[n - 1].h.type, STAC_MSG_INFO);
    CHECK_EQ(g_app.stats.command_errors, 3);
    CHECK_EQ(g_app.stats.rx_frames, 4);
}

TEST(cmd_corrupted_frames_are_counted_not_answered) {
    boot();
    uint8_t wire[STAC_MAX_FRAME];
    size_t w = stac_frame_encode(STAC_MSG_GET_INFO, 1, NULL, 0, wire, sizeof wire);
    wire[3] = (uint8_t)(wire[3] == 0x77 ? 0x78 : 0x77); /* CRC no longer matches */
    fake_send_raw(&g_b, wire, w);
    const uint8_t bad_cobs[4] = {0x09, 0x01, 0x02, 0x00};
    fake_send_raw(&g_b, bad_cobs, sizeof bad_cobs);
    const uint8_t too_short[4] = {0x03, 0x01, 0x02, 0x00};
    fake_send_raw(&g_b, too_short, sizeof too_short);
    uint8_t run[400];
    memset(run, 0x42, sizeof run);
    fake_send_raw(&g_b, run, sizeof run);
    const uint8_t z = 0;
    fake_send_raw(&g_b, &z, 1);
    int n = pass();
    CHECK_EQ(n, 0);
    CHECK_EQ(g_app.stats.rx_errors, 4);
    /* And the link still works right after. */
    w = stac_frame_encode(STAC_MSG_GET_STATUS, 2, NULL, 0, wire, sizeof wire);
    fake_send_raw(&g_b, wire, w);
    n = pass();
    CHECK_EQ(n, 1);
    stac_status_t st;
    stac_status_unpack(&st, g_frames[0].payload, g_frames[0].len);
    CHECK_EQ(st.rx_errors, 4);
    CHECK_EQ(st.rx_frames, 1);
    CHECK_EQ(st.sensor_present, 7);
    CHECK_EQ(st.streaming, 0);
}

TEST(cmd_time_sync_echoes) {
    boot();
    stac_time_sync_request_t r = {.exchange_id = 0xCAFEF00Du,
                                  .host_time_ns = 0x0123456789ABCDEFull};
    uint8_t p[STAC_TIME_SYNC_REQUEST_SIZE];
    fake_send(&g_b, STAC_MSG_TIME_SYNC_REQUEST, 5, p, stac_time_sync_request_pack(&r, p));
    const uint32_t t = g_b.now;
    const int n = pass();
    CHECK_EQ(n, 1);
    stac_time_sync_reply_t rep;
    stac_time_sync_reply_unpack(&rep, g_frames[0].payload, g_frames[0].len);
    CHECK_EQ(rep.exchange_id, 0xCAFEF00Du);
    CHECK(rep.host_time_ns == 0x0123456789ABCDEFull);
    CHECK_EQ(rep.device_rx_us, t);
    CHECK(rep.device_tx_us - rep.device_rx_us < 1000u);
}

TEST(cmd_status_and_reset_stats) {
    boot();
    h_send_empty(&g_b, 0x31, 1); /* one NACK */
    h_send_empty(&g_b, STAC_MSG_START, 2);
    pass();
    fake_run_until(&g_b, &g_app, g_b.now + 1000000u, 100u);
    h_send_empty(&g_b, STAC_MSG_GET_STATUS, 3);
    int n = pass();
    stac_status_t st;
    const fake_frame_t *f = fake_last(g_frames, n, STAC_MSG_STATUS);
    stac_status_unpack(&st, f->payload, f->len);
    CHECK_EQ(st.streaming, 1);
    CHECK(st.samples_taken >= 18);
    CHECK_EQ(st.command_errors, 1);
    CHECK_EQ(st.frames_sent, (uint32_t)(n - 1)); /* STATUS counted after it was built */
    CHECK(st.uptime_ms >= 1000);
    h_send_empty(&g_b, STAC_MSG_RESET_STATS, 4);
    h_send_empty(&g_b, STAC_MSG_GET_STATUS, 5);
    n = pass();
    f = fake_last(g_frames, n, STAC_MSG_STATUS);
    stac_status_unpack(&st, f->payload, f->len);
    CHECK_EQ(st.samples_taken, 0);
    CHECK_EQ(st.command_errors, 0);
    CHECK_EQ(st.frames_sent, 1); /* the RESET_STATS ACK */
    CHECK_EQ(st.rx_frames, 1);   /* the GET_STATUS */
    CHECK(st.uptime_ms >= 1000); /* uptime is not a statistic */
}

TEST(cmd_bad_input_does_not_stop_streaming) {
    boot();
    h_send_empty(&g_b, STAC_MSG_START, 1);
    fake_run_until(&g_b, &g_app, g_b.now + 500000u, 100u);
    stac_configure_t c;
    stac_default_config(&c);
    c.led_step_count = 12;
    h_send_configure(&g_b, &c, 2);
    const uint8_t garbage[6] = {0x13, 0x37, 0x00, 0xFF, 0x01, 0x00};
    fake_send_raw(&g_b, garbage, sizeof garbage);
    h_send_empty(&g_b, 0x7F, 3);
    fake_run_until(&g_b, &g_app, g_b.now + 500000u, 100u);
    const int n = h_frames(&g_b);
    stac_sample_t s[64];
    const int ns = h_samples(n, s, 64);
    CHECK(ns >= 18);
    for (int i = 0; i < ns; i++) {
        CHECK_EQ(s[i].sample_seq, i);
        CHECK_EQ(s[i].config_id, 0);
    }
    CHECK_EQ(fake_count(g_frames, n, STAC_MSG_NACK), 2);
    CHECK_EQ(g_app.stats.rx_errors, 2);
}

TEST(cmd_configure_stream_flag_starts) {
    boot();
    stac_configure_t c;
    stac_default_config(&c);
    c.flags = STAC_CONFIG_STREAM;
    h_send_configure(&g_b, &c, 1);
    fake_run_until(&g_b, &g_app, g_b.now + 300000u, 100u);
    const int n = h_frames(&g_b);
    CHECK_EQ(g_frames[0].h.type, STAC_MSG_ACK);
    CHECK(fake_count(g_frames, n, STAC_MSG_SAMPLE) >= 4);
    /* START while streaming is acknowledged and changes nothing. */
    h_send_empty(&g_b, STAC_MSG_START, 2);
    fake_run_until(&g_b, &g_app, g_b.now + 300000u, 100u);
    stac_sample_t s[64];
    const int ns = h_samples(h_frames(&g_b), s, 64);
    for (int i = 0; i < ns; i++) {
        CHECK_EQ(s[i].sample_seq, i);
    }
}

TEST(cmd_payload_shorter_than_the_senders_version_is_malformed) {
    boot();
    stac_time_sync_request_t r = {.exchange_id = 7u, .host_time_ns = 9u};
    uint8_t p[STAC_TIME_SYNC_REQUEST_SIZE];
    stac_time_sync_request_pack(&r, p);
    static const size_t lengths[] = {0u, 2u, STAC_TIME_SYNC_REQUEST_SIZE - 1u};
    for (size_t i = 0; i < 3u; i++) {
        fake_send(&g_b, STAC_MSG_TIME_SYNC_REQUEST, (uint16_t)(20u + i), p, lengths[i]);
        const int n = pass();
        CHECK_EQ(g_frames[n - 1].h.type, STAC_MSG_NACK); /* not a zero-filled reply */
        const stac_nack_t m = last_nack(n);
        CHECK_EQ(m.rejected_type, STAC_MSG_TIME_SYNC_REQUEST);
        CHECK_EQ(m.rejected_seq, 20u + i);
        CHECK_EQ(m.error, STAC_MALFORMED);
    }
    CHECK_EQ(g_app.stats.command_errors, 3);
    CHECK_EQ(fake_count(g_frames, h_frames(&g_b), STAC_MSG_TIME_SYNC_REPLY), 0);
    /* The whole 1.0 layout is served. */
    fake_send(&g_b, STAC_MSG_TIME_SYNC_REQUEST, 30, p, sizeof p);
    const int n = pass();
    CHECK_EQ(g_frames[n - 1].h.type, STAC_MSG_TIME_SYNC_REPLY);
}

TEST(cmd_stop_is_idempotent) {
    boot();
    h_send_empty(&g_b, STAC_MSG_STOP, 1); /* while idle */
    h_send_empty(&g_b, STAC_MSG_START, 2);
    fake_run_until(&g_b, &g_app, g_b.now + 300000u, 100u);
    h_send_empty(&g_b, STAC_MSG_STOP, 3);
    h_send_empty(&g_b, STAC_MSG_STOP, 4); /* a resend whose first ACK was lost */
    fake_run_until(&g_b, &g_app, g_b.now + 300000u, 100u);
    const int n = h_frames(&g_b);
    int acks = 0;
    int last_ack = -1;
    int last_sample = -1;
    for (int i = 0; i < n; i++) {
        if (g_frames[i].h.type == STAC_MSG_ACK) {
            stac_ack_t a;
            stac_ack_unpack(&a, g_frames[i].payload, g_frames[i].len);
            CHECK_EQ(a.acked_seq, (uint16_t)(acks + 1));
            acks++;
            last_ack = i;
        } else if (g_frames[i].h.type == STAC_MSG_SAMPLE) {
            last_sample = i;
        }
    }
    CHECK_EQ(acks, 4);
    CHECK(last_sample >= 0 && last_sample < last_ack); /* nothing after the STOPs */
    CHECK(!g_app.streaming);
    CHECK_EQ(g_app.stats.command_errors, 0);
    /* START after the repeated STOPs streams again. */
    h_send_empty(&g_b, STAC_MSG_START, 5);
    fake_run_until(&g_b, &g_app, g_b.now + 300000u, 100u);
    CHECK(fake_count(g_frames, h_frames(&g_b), STAC_MSG_SAMPLE) > fake_count(g_frames, n,
                                                                           STAC_MSG_SAMPLE));
}

const test_case_t g_cmd_tests[] = {
    {"cmd_get_info", cmd_get_info},
    {"cmd_default_config", cmd_default_config},
    {"cmd_configure_rejections_name_the_field", cmd_configure_rejections_name_the_field},
    {"cmd_configure_accepted_and_reported", cmd_configure_accepted_and_reported},
    {"cmd_short_and_long_payloads", cmd_short_and_long_payloads},
    {"cmd_unknown_wrong_direction_version", cmd_unknown_wrong_direction_version},
    {"cmd_corrupted_frames_are_counted_not_answered",
     cmd_corrupted_frames_are_counted_not_answered},
    {"cmd_time_sync_echoes", cmd_time_sync_echoes},
    {"cmd_status_and_reset_stats", cmd_status_and_reset_stats},
    {"cmd_bad_input_does_not_stop_streaming", cmd_bad_input_does_not_stop_streaming},
    {"cmd_configure_stream_flag_starts", cmd_configure_stream_flag_starts},
    {"cmd_payload_shorter_than_the_senders_version_is_malformed",
     cmd_payload_shorter_than_the_senders_version_is_malformed},
    {"cmd_stop_is_idempotent", cmd_stop_is_idempotent},
    {NULL, NULL},
};
