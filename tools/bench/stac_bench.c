/* Timing probe for tools/bench/firmware.py (native build, -O2). Prints one `key value` per line:
 *   encode_ns / memcpy_ns: framing a SAMPLE (pack + CRC-32C + COBS) vs copying the same bytes,
 *                          measured alternately, best of several rounds, ns per frame;
 *   frame_bytes:           encoded SAMPLE size;
 *   pass_us / idle_pass_us: the superloop pass that sees an integration end, reads the three
 *                          sensors, builds and hands the SAMPLE to the UART, vs an idle pass
 *                          (in-memory sensors answering instantly: the core's own cost). */
#define _POSIX_C_SOURCE 199309L
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "stac_app.h"
#include "stac_frame.h"
#include "veml3328.h"

static double now_ns(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec * 1e9 + (double)ts.tv_nsec;
}

/* Instant sensors: TRIG clears as soon as it is read back, data registers fixed. */
typedef struct bench_board {
    uint32_t now;
    uint16_t conf[3];
    uint32_t frames;
} bench_board_t;

static int32_t b_i2c(void *ctx, uint8_t bus, uint8_t addr7, const uint8_t *wr, uint32_t wr_len,
                     uint8_t *rd, uint32_t rd_len, uint32_t timeout_us) {
    bench_board_t *b = (bench_board_t *)ctx;
    (void)addr7;
    (void)timeout_us;
    if (wr_len == 3u) {
        b->conf[bus] = (uint16_t)(wr[1] | (wr[2] << 8));
        return STAC_I2C_OK;
    }
    uint16_t v = 0x1234u;
    if (wr[0] == VEML3328_REG_ID) {
        v = 0x0028u;
    } else if (wr[0] == VEML3328_REG_CONF) {
        v = b->conf[bus] & (uint16_t)~VEML3328_CONF_TRIG;
    }
    if (rd_len == 2u) {
        rd[0] = (uint8_t)v;
        rd[1] = (uint8_t)(v >> 8);
    }
    return STAC_I2C_OK;
}

static void b_pwm(void *ctx, uint8_t led, uint8_t colour, uint16_t duty) {
    (void)ctx;
    (void)led;
    (void)colour;
    (void)duty;
}

static uint32_t b_write(void *ctx, const uint8_t *data, uint32_t len) {
    (void)data;
    ((bench_board_t *)ctx)->frames++;
    return len;
}

static const uint8_t *g_rx;
static uint32_t g_rx_len;

static uint32_t b_read(void *ctx, uint8_t *buf, uint32_t cap) {
    (void)ctx;
    const uint32_t n = g_rx_len < cap ? g_rx_len : cap;
    memcpy(buf, g_rx, n);
    g_rx += n;
    g_rx_len -= n;
    return n;
}

static uint32_t b_clock(void *ctx) {
    return ((bench_board_t *)ctx)->now;
}

static void b_uid(void *ctx, uint8_t uid[STAC_UID_SIZE]) {
    (void)ctx;
    memset(uid, 0x5A, STAC_UID_SIZE);
}

static volatile uint8_t g_sink;

static int cmp_double(const void *a, const void *b) {
    const double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static double median(double *v, size_t n) {
    qsort(v, n, sizeof v[0], cmp_double);
    return n == 0u ? 0.0 : v[n / 2u];
}

int main(void) {
    /* Framing cost of a typical SAMPLE. */
    stac_sample_t s;
    memset(&s, 0, sizeof s);
    for (int k = 0; k < 3; k++) {
        for (int c = 0; c < 5; c++) {
            s.counts[k][c] = (uint16_t)(1000 + 37 * (5 * k + c));
        }
    }
    s.t_start_us = 123456u;
    s.t_end_us = 173456u;
    uint8_t payload[STAC_SAMPLE_SIZE];
    uint8_t out[STAC_MAX_FRAME];
    uint8_t copy[STAC_MAX_FRAME];
    const size_t plen = stac_sample_pack(&s, payload);
    const size_t flen = stac_frame_encode(STAC_MSG_SAMPLE, 1, payload, plen, out, sizeof out);
    const int n = 200000;
    double best_enc = 1e30, best_cpy = 1e30;
    for (int round = 0; round < 7; round++) {
        double t0 = now_ns();
        for (int i = 0; i < n; i++) {
            s.sample_seq = (uint32_t)i;
            const size_t pl = stac_sample_pack(&s, payload);
            g_sink ^= (uint8_t)stac_frame_encode(STAC_MSG_SAMPLE, (uint16_t)i, payload, pl, out,
                                                 sizeof out);
        }
        double t1 = now_ns();
        for (int i = 0; i < n; i++) {
            out[0] = (uint8_t)i;
            memcpy(copy, out, flen);
            __asm__ __volatile__("" : : "r"(copy) : "memory"); /* keep the copy */
            g_sink ^= copy[flen - 1u];
        }
        double t2 = now_ns();
        if ((t1 - t0) / n < best_enc) best_enc = (t1 - t0) / n;
        if ((t2 - t1) / n < best_cpy) best_cpy = (t2 - t1) / n;
    }
    printf("encode_ns %.2f\nmemcpy_ns %.2f\nframe_bytes %zu\n", best_enc, best_cpy, flen);

    /* The pass that ends an integration, vs an idle pass. */
    static bench_board_t board;
    static stac_app_t app;
    const stac_hal_t hal = {.ctx = &board,
                            .i2c_transfer = b_i2c,
                            .pwm_set = b_pwm,
                            .link_write = b_write,
                            .link_read = b_read,
                            .clock_us = b_clock,
                            .unique_id = b_uid}; /* no model store, watchdog or cycle counter */
    stac_identity_t id;
    memset(&id, 0, sizeof id);
    board.now = 1000u;
    stac_app_init(&app, &hal, &id, board.now);
    uint8_t start[16];
    const size_t sl = stac_frame_encode(STAC_MSG_START, 1, NULL, 0, start, sizeof start);
    g_rx = start;
    g_rx_len = (uint32_t)sl;
    stac_app_step(&app, board.now);
    static double pass[4000], idle[4000];
    size_t np = 0u, ni = 0u;
    for (int i = 0; i < 4000; i++) {
        board.now = stac_app_next_wake_us(&app) + 10u;
        const uint32_t frames = board.frames;
        double t0 = now_ns();
        stac_app_step(&app, board.now);
        double t1 = now_ns();
        if (board.frames != frames) {
            pass[np++] = t1 - t0;
        }
        board.now += 1u;
        double t2 = now_ns();
        stac_app_step(&app, board.now); /* nothing due: an idle pass */
        double t3 = now_ns();
        idle[ni++] = t3 - t2;
    }
    printf("pass_us %.3f\nidle_pass_us %.3f\nsamples %u\n", median(pass, np) / 1000.0,
           median(idle, ni) / 1000.0, board.frames);
    return g_sink == 0xFFu ? 0 : 0;
}
