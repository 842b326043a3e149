/* Acquisition (stac_acquisition): timing, rates, LED settling, per-step tagging, failing
 * sensors. */
#include <string.h>

#include "check.h"
#include "helpers.h"
#include "stac_acquisition.h"
#include "veml3328.h"

static fake_board_t g_b;
static stac_app_t g_app;
static stac_sample_t g_s[1024];

static void boot(void) {
    fake_init(&g_b);
    fake_boot(&g_b, &g_app);
}

static void start(void) {
    h_send_empty(&g_b, STAC_MSG_START, 1);
    g_b.pass++;
    stac_app_step(&g_app, g_b.now);
}

TEST(acquisition_silent_until_asked) {
    boot();
    fake_run_until(&g_b, &g_app, g_b.now + 2000000u, 500u);
    CHECK_EQ(g_b.tx_len, 0);
    CHECK_EQ(g_b.s[0].triggers, 0);
    /* LEDs dark while idle. */
    for (int l = 0; l < 3; l++) {
        for (int c = 0; c < 3; c++) {
            CHECK_EQ(g_b.duty[l][c], 0);
        }
    }
}

TEST(acquisition_one_step_20_per_second) {
    boot();
    start();
    const uint32_t t0 = g_b.now;
    fake_run_until(&g_b, &g_app, t0 + 10000000u, 100u);
    const int n = h_frames(&g_b);
    CHECK(n > 0);
    const int ns = h_samples(n, g_s, 1024);
    /* 50 ms integrations back to back: 200 in 10 s, less the polling and bus overhead. */
    CHECK(ns >= 190 && ns <= 200);
    for (int i = 0; i < ns; i++) {
        CHECK_EQ(g_s[i].sample_seq, i);
        CHECK_EQ(g_s[i].led_step, 0);
        CHECK_EQ(g_s[i].config_id, 0);
        CHECK(g_s[i].t_end_us - g_s[i].t_start_us >= 50000u);
        for (int k = 0; k < 3; k++) {
            CHECK_EQ(g_s[i].sensor_status[k], 0);
        }
        if (i > 0) {
            /* One cycle per integration: no settle wait when the LEDs do not change. */
            CHECK(g_s[i].t_start_us - g_s[i - 1].t_start_us < 52000u);
        }
    }
    /* Default duties: all nine at 500 permille. */
    CHECK_EQ(g_s[0].counts[0][0], 1000 + 9 * 500);
}

static void four_steps(stac_configure_t *c) {
    stac_default_config(c);
    c->led_step_count = 4;
    c->led_settle_us = 1000;
    for (int s = 0; s < 4; s++) {
        for (int l = 0; l < 3; l++) {
            for (int col = 0; col < 3; col++) {
                c->led_duty[s][l][col] = (uint16_t)((l * 3 + col) == s * 2 ? 100 * (s + 1) : 0);
            }
        }
    }
}

TEST(acquisition_n_steps_rate_and_tagging) {
    boot();
    stac_configure_t c;
    four_steps(&c);
    c.flags = STAC_CONFIG_STREAM;
    h_send_configure(&g_b, &c, 7);
    const uint32_t t0 = g_b.now;
    fake_run_until(&g_b, &g_app, t0 + 10000000u, 100u);
    const int n = h_frames(&g_b);
    const int ns = h_samples(n, g_s, 1024);
    /* Each cycle: 1 ms settle + 50 ms integration (+ bus time): ~19.4 cycles/s in total,
     * so each of the 4 steps is sampled ~20/4 times per second. */
    CHECK(ns >= 185 && ns <= 197);
    int per_step[4] = {0, 0, 0, 0};
    for (int i = 0; i < ns; i++) {
        CHECK_EQ(g_s[i].led_step, i % 4);
        CHECK_EQ(g_s[i].config_id, 1);
        per_step[g_s[i].led_step]++;
        /* The fake's counts carry the duties lit when the integration started. */
        CHECK_EQ(g_s[i].counts[0][0], 1000 + 100 * (g_s[i].led_step + 1));
    }
    for (int s = 0; s < 4; s++) {
        CHECK(per_step[s] >= ns / 4 - 1 && per_step[s] <= ns / 4 + 1);
    }
}

TEST(acquisition_no_integration_straddles_led_change) {
    boot();
    stac_configure_t c;
    four_steps(&c);
    c.flags = STAC_CONFIG_STREAM;
    c.led_settle_us = 700;
    h_send_configure(&g_b, &c, 7);
    fake_run_until(&g_b, &g_app, g_b.now + 3000000u, 100u);
    CHECK(g_b.n_win > 100);
    for (size_t w = 0; w < g_b.n_win; w++) {
        for (size_t e = 0; e < g_b.n_pwm; e++) {
            const uint32_t t = g_b.pwm[e].t;
            /* No change inside a window, and none within the settle time before it. */
            CHECK(!((int32_t)(t - (g_b.win[w].start - 700u)) >= 0 &&
                    (int32_t)(t - g_b.win[w].end) < 0));
        }
    }
}

TEST(acquisition_sample_sent_in_the_pass_that_sees_the_end) {
    boot();
    start();
    fake_run_until(&g_b, &g_app, g_b.now + 2000000u, 100u);
    const int n = h_frames(&g_b);
    int checked = 0;
    for (int i = 0; i < n && i < 1024; i++) {
        if (g_frames[i].h.type == STAC_MSG_SAMPLE) {
            CHECK_EQ(g_b.tx_pass[i], g_b.tx_done_pass[i]);
            checked++;
        }
    }
    CHECK(checked > 30);
}

TEST(acquisition_missing_sensor_flagged_others_stream) {
    fake_init(&g_b);
    g_b.s[1].mode = FAKE_ABSENT;
    fake_boot(&g_b, &g_app);
    CHECK_EQ(g_app.present, 0x5);
    start();
    fake_run_until(&g_b, &g_app, g_b.now + 2000000u, 100u);
    const int ns = h_samples(h_frames(&g_b), g_s, 1024);
    CHECK(ns >= 38);
    for (int i = 0; i < ns; i++) {
        CHECK_EQ(g_s[i].sensor_status[0], 0);
        CHECK_EQ(g_s[i].sensor_status[1], STAC_SENSOR_ABSENT);
        CHECK_EQ(g_s[i].sensor_status[2], 0);
        CHECK_EQ(g_s[i].counts[1][3], 0);
        CHECK_EQ(g_s[i].counts[2][3], 3000 + 300 + 4500);
    }
}

TEST(acquisition_sensor_lost_and_recovered) {
    boot();
    start();
    fake_run_until(&g_b, &g_app, g_b.now + 500000u, 100u);
    g_b.s[2].mode = FAKE_STALL;
    fake_run_until(&g_b, &g_app, g_b.now + 1000000u, 100u);
    g_b.s[2].mode = FAKE_OK;
    fake_run_until(&g_b, &g_app, g_b.now + 1000000u, 100u);
    const int n = h_frames(&g_b);
    const int ns = h_samples(n, g_s, 1024);
    int faulted = 0;
    int good_after = 0;
    for (int i = 0; i < ns; i++) {
        CHECK_EQ(g_s[i].sample_seq, i); /* the other sensors never stopped */
        CHECK_EQ(g_s[i].sensor_status[0], 0);
        if (g_s[i].sensor_status[2] == STAC_SENSOR_BUS_FAULT) {
            faulted++;
            CHECK_EQ(g_s[i].counts[2][0], 0);
        } else if (faulted > 0) {
            good_after++;
        }
    }
    CHECK(faulted >= 15);
    CHECK(good_after >= 15);
    CHECK(g_app.stats.bus_errors[2] >= (uint32_t)faulted);
    CHECK_EQ(g_app.stats.bus_errors[0], 0);
    /* One LOG when lost, one when recovered: no flood. */
    CHECK_EQ(fake_count(g_frames, n, STAC_MSG_LOG), 2);
    const fake_frame_t *lg = fake_last(g_frames, n, STAC_MSG_LOG);
    stac_log_t m;
    stac_log_unpack(&m, lg->payload, lg->len);
    CHECK(strcmp(m.text, "sensor 2 recovered") == 0);
}

TEST(acquisition_flapping_sensor_logs_are_rate_limited) {
    boot();
    start();
    for (int i = 0; i < 40; i++) {
        g_b.s[0].mode = (i % 2) ? FAKE_OK : FAKE_BUS_ERROR;
        fake_run_until(&g_b, &g_app, g_b.now + 60000u, 100u);
    }
    const int n = h_frames(&g_b);
    /* 40 transitions in ~2.4 s: a burst of 4 plus about one per second. */
    CHECK(fake_count(g_frames, n, STAC_MSG_LOG) <= 7);
    CHECK(fake_count(g_frames, n, STAC_MSG_SAMPLE) >= 40);
}

TEST(acquisition_never_finishing_sensor_is_stale) {
    boot();
    start();
    fake_run_until(&g_b, &g_app, g_b.now + 300000u, 100u);
    g_b.s[1].mode = FAKE_NEVER_DONE;
    fake_run_until(&g_b, &g_app, g_b.now + 1000000u, 100u);
    const int ns = h_samples(h_frames(&g_b), g_s, 1024);
    const stac_sample_t *last = &g_s[ns - 1];
    CHECK_EQ(last->sensor_status[1], STAC_SENSOR_STALE);
    CHECK_EQ(last->counts[1][0], 2000 + 4500); /* the last good reading, repeated */
    CHECK_EQ(last->sensor_status[0], 0);
    /* The window waits for the stale sensor up to its deadline, not for ever. */
    CHECK(last->t_end_us - last->t_start_us <= 50000u + STAC_STALE_MARGIN_US(50000u) + 3000u);
}

TEST(acquisition_saturation_flagged_and_counted) {
    boot();
    g_b.s[0].saturate = true;
    start();
    fake_run_until(&g_b, &g_app, g_b.now + 1000000u, 100u);
    const int ns = h_samples(h_frames(&g_b), g_s, 1024);
    CHECK(ns >= 18);
    CHECK_EQ(g_s[0].sensor_status[0], STAC_SENSOR_SATURATED);
    CHECK_EQ(g_s[0].sensor_status[1], 0);
    CHECK_EQ(g_app.stats.saturations[0], (uint32_t)ns);
    CHECK_EQ(g_app.stats.saturations[1], 0);
}

TEST(acquisition_slow_sensor_oscillator_is_waited_for) {
    boot();
    for (int k = 0; k < 3; k++) {
        g_b.s[k].slow_ppm = 80000u; /* 8 % slow: 54 ms per 50 ms integration */
    }
    start();
    fake_run_until(&g_b, &g_app, g_b.now + 1000000u, 100u);
    const int ns = h_samples(h_frames(&g_b), g_s, 1024);
    CHECK(ns >= 17);
    for (int i = 0; i < ns; i++) {
        CHECK_EQ(g_s[i].sensor_status[0] | g_s[i].sensor_status[1] | g_s[i].sensor_status[2], 0);
        CHECK(g_s[i].t_end_us - g_s[i].t_start_us >= 54000u);
    }
}

TEST(acquisition_config_applies_at_next_integration) {
    boot();
    start();
    fake_run_until(&g_b, &g_app, g_b.now + 120000u, 100u); /* mid-integration */
    stac_configure_t c;
    stac_default_config(&c);
    c.integration_ms = 100;
    h_send_configure(&g_b, &c, 9);
    fake_run_until(&g_b, &g_app, g_b.now + 1000000u, 100u);
    const int n = h_frames(&g_b);
    const fake_frame_t *ack = fake_last(g_frames, n, STAC_MSG_ACK);
    stac_ack_t a;
    stac_ack_unpack(&a, ack->payload, ack->len);
    CHECK_EQ(a.acked_type, STAC_MSG_CONFIGURE);
    CHECK_EQ(a.acked_seq, 9);
    CHECK_EQ(a.config_id, 1);
    const int ns = h_samples(n, g_s, 1024);
    int old_cfg = 0;
    for (int i = 0; i < ns; i++) {
        if (g_s[i].config_id == 0) {
            old_cfg++;
            CHECK(g_s[i].t_end_us - g_s[i].t_start_us < 60000u);
        } else {
            CHECK_EQ(g_s[i].config_id, 1);
            CHECK(g_s[i].t_end_us - g_s[i].t_start_us >= 100000u);
            CHECK_EQ(g_s[i].sample_seq, i); /* streaming did not restart */
        }
    }
    CHECK(old_cfg >= 2 && old_cfg <= 3); /* the one in flight finished under config 0 */
    CHECK((g_b.s[0].conf & 0x0030u) == 0x0010u);
}

TEST(acquisition_stop_means_no_more_samples) {
    boot();
    start();
    fake_run_until(&g_b, &g_app, g_b.now + 275000u, 100u);
    h_send_empty(&g_b, STAC_MSG_STOP, 5);
    fake_run_until(&g_b, &g_app, g_b.now + 1000000u, 100u);
    const int n = h_frames(&g_b);
    int ack_at = -1;
    for (int i = 0; i < n; i++) {
        if (g_frames[i].h.type == STAC_MSG_ACK && g_frames[i].payload[0] == STAC_MSG_STOP) {
            ack_at = i;
        }
    }
    CHECK(ack_at > 0);
    for (int i = ack_at; i < n; i++) {
        CHECK(g_frames[i].h.type != STAC_MSG_SAMPLE);
    }
    CHECK_EQ(g_b.duty[0][0], 0);
    CHECK(!g_app.streaming);
    /* A restart numbers samples from 0 again and does not cut a running integration. */
    const uint32_t triggers = g_b.s[0].triggers;
    fake_clear_tx(&g_b);
    start();
    fake_run_until(&g_b, &g_app, g_b.now + 500000u, 100u);
    const int ns = h_samples(h_frames(&g_b), g_s, 1024);
    CHECK(ns >= 8);
    CHECK_EQ(g_s[0].sample_seq, 0);
    CHECK(g_b.s[0].triggers > triggers);
}

TEST(acquisition_all_sensors_absent_still_streams) {
    fake_init(&g_b);
    for (int k = 0; k < 3; k++) {
        g_b.s[k].mode = FAKE_STALL;
    }
    fake_boot(&g_b, &g_app);
    CHECK_EQ(g_app.present, 0);
    start();
    fake_run_until(&g_b, &g_app, g_b.now + 1000000u, 100u);
    const int ns = h_samples(h_frames(&g_b), g_s, 1024);
    CHECK(ns >= 17 && ns <= 20);
    for (int k = 0; k < 3; k++) {
        CHECK_EQ(g_s[0].sensor_status[k], STAC_SENSOR_ABSENT);
    }
}

TEST(acquisition_full_transmit_buffer_counts_drops) {
    boot();
    start();
    fake_run_until(&g_b, &g_app, g_b.now + 500000u, 100u);
    g_b.tx_full = true;
    fake_run_until(&g_b, &g_app, g_b.now + 500000u, 100u);
    g_b.tx_full = false;
    fake_run_until(&g_b, &g_app, g_b.now + 500000u, 100u);
    const int n = h_frames(&g_b);
    const int ns = h_samples(n, g_s, 1024);
    CHECK(g_app.stats.frames_dropped >= 8);
    CHECK_EQ(g_app.stats.frames_sent, (uint32_t)n);
    /* Sample numbering exposes the loss; the device seq too. */
    CHECK(g_s[ns - 1].sample_seq > (uint32_t)(ns - 1));
    CHECK(g_frames[n - 1].h.seq > (uint16_t)(n - 1));
}

TEST(acquisition_trig_latency_measured_per_sensor) {
    boot();
    g_b.s[2].slow_ppm = 80000u; /* 54 ms per 50 ms integration */
    start();
    fake_run_until(&g_b, &g_app, g_b.now + 1000000u, 100u);
    const int ns = h_samples(h_frames(&g_b), g_s, 1024);
    CHECK(ns >= 17);
    for (int k = 0; k < 3; k++) {
        const uint32_t conv = k == 2 ? 54000u : 50000u;
        const uint32_t last = g_app.stats.trig_latency_us_last[k];
        /* found clear at the first poll after the conversion: within one poll interval and
         * the transfers of that pass */
        CHECK(last >= conv);
        CHECK(last <= conv + STAC_POLL_INTERVAL_US + 1000u);
        CHECK(g_app.stats.trig_latency_us_max[k] >= last);
        CHECK(g_app.stats.trig_latency_us_max[k] <= conv + STAC_POLL_INTERVAL_US + 1000u);
        CHECK_EQ(g_app.stats.trig_stuck[k], 0);
    }
}

TEST(acquisition_sensor_keeping_trig_set_is_read_by_time) {
    /* If the VEML3328 does not clear TRIG itself, its samples must not all go stale. This one
     * also starts a conversion only on a TRIG 0 -> 1 write, the stricter of the two readings. */
    boot();
    g_b.s[1].trig_stays = true;
    start();
    fake_run_until(&g_b, &g_app, g_b.now + 1000000u, 100u);
    const int n = h_frames(&g_b);
    const int ns = h_samples(n, g_s, 1024);
    /* each window waits for the deadline: ~64.5 ms instead of ~50 */
    CHECK(ns >= 14);
    for (int i = 0; i < ns; i++) {
        CHECK_EQ(g_s[i].sensor_status[1], 0);
        CHECK_EQ(g_s[i].counts[1][0], 2000 + 4500);
        CHECK_EQ(g_s[i].sensor_status[0] | g_s[i].sensor_status[2], 0);
        CHECK(g_s[i].t_end_us - g_s[i].t_start_us <= 50000u + STAC_STALE_MARGIN_US(50000u) + 3000u);
    }
    CHECK(g_b.s[1].triggers >= (uint32_t)ns); /* a fresh conversion for every sample */
    CHECK(g_app.stats.trig_stuck[1] >= (uint32_t)ns);
    CHECK_EQ(g_app.stats.trig_stuck[0], 0);
    CHECK_EQ(g_app.stats.trig_latency_us_last[1], 0); /* never seen clear: not measured */
    CHECK(g_app.stats.trig_latency_us_last[0] >= 50000u);
    CHECK_EQ(fake_count(g_frames, n, STAC_MSG_LOG), 1); /* said once */
}

TEST(acquisition_sensor_keeping_trig_set_and_never_converting_is_stale) {
    boot();
    start();
    fake_run_until(&g_b, &g_app, g_b.now + 300000u, 100u);
    g_b.s[1].trig_stays = true;
    g_b.s[1].mode = FAKE_NEVER_DONE;
    fake_run_until(&g_b, &g_app, g_b.now + 1000000u, 100u);
    const int ns = h_samples(h_frames(&g_b), g_s, 1024);
    CHECK_EQ(g_s[ns - 1].sensor_status[1], STAC_SENSOR_STALE);
    CHECK(g_app.stats.trig_stuck[1] >= 10u);
}

const test_case_t g_acquisition_tests[] = {
    {"acquisition_silent_until_asked", acquisition_silent_until_asked},
    {"acquisition_one_step_20_per_second", acquisition_one_step_20_per_second},
    {"acquisition_n_steps_rate_and_tagging", acquisition_n_steps_rate_and_tagging},
    {"acquisition_no_integration_straddles_led_change",
     acquisition_no_integration_straddles_led_change},
    {"acquisition_sample_sent_in_the_pass_that_sees_the_end",
     acquisition_sample_sent_in_the_pass_that_sees_the_end},
    {"acquisition_missing_sensor_flagged_others_stream",
     acquisition_missing_sensor_flagged_others_stream},
    {"acquisition_sensor_lost_and_recovered", acquisition_sensor_lost_and_recovered},
    {"acquisition_flapping_sensor_logs_are_rate_limited",
     acquisition_flapping_sensor_logs_are_rate_limited},
    {"acquisition_never_finishing_sensor_is_stale", acquisition_never_finishing_sensor_is_stale},
    {"acquisition_saturation_flagged_and_counted", acquisition_saturation_flagged_and_counted},
    {"acquisition_slow_sensor_oscillator_is_waited_for",
     acquisition_slow_sensor_oscillator_is_waited_for},
    {"acquisition_config_applies_at_next_integration",
     acquisition_config_applies_at_next_integration},
    {"acquisition_stop_means_no_more_samples", acquisition_stop_means_no_more_samples},
    {"acquisition_all_sensors_absent_still_streams", acquisition_all_sensors_absent_still_streams},
    {"acquisition_full_transmit_buffer_counts_drops",
     acquisition_full_transmit_buffer_counts_drops},
    {"acquisition_trig_latency_measured_per_sensor",
     acquisition_trig_latency_measured_per_sensor},
    {"acquisition_sensor_keeping_trig_set_is_read_by_time",
     acquisition_sensor_keeping_trig_set_is_read_by_time},
    {"acquisition_sensor_keeping_trig_set_and_never_converting_is_stale",
     acquisition_sensor_keeping_trig_set_and_never_converting_is_stale},
    {NULL, NULL},
};
