/* Random bytes into the command decoder: it never crashes (ASan/UBSan watch), never answers
 * garbage with anything but well-formed frames, and always recovers at the next delimiter. */
#include <string.h>

#include "check.h"
#include "helpers.h"

static fake_board_t g_b;
static stac_app_t g_app;
static uint32_t g_rng = 0xC0FFEEu;

static uint32_t rnd(void) {
    g_rng ^= g_rng << 13;
    g_rng ^= g_rng >> 17;
    g_rng ^= g_rng << 5;
    return g_rng;
}

TEST(fuzz_random_bytes_then_recover) {
    for (int round = 0; round < 300; round++) {
        fake_init(&g_b);
        fake_boot(&g_b, &g_app);
        uint8_t junk[700];
        const size_t n = rnd() % sizeof junk;
        for (size_t i = 0; i < n; i++) {
            /* Mostly non-zero so long runs (oversize) happen as well as short frames. */
            junk[i] = (rnd() % 8u == 0u) ? 0u : (uint8_t)rnd();
        }
        fake_send_raw(&g_b, junk, n);
        for (int p = 0; p < 4; p++) {
            stac_app_step(&g_app, g_b.now);
            g_b.now += 100u;
        }
        CHECK(h_frames(&g_b) >= 0); /* whatever was answered is well formed */
        fake_clear_tx(&g_b);
        const uint8_t z = 0;
        fake_send_raw(&g_b, &z, 1);
        h_send_empty(&g_b, STAC_MSG_GET_INFO, 77);
        stac_app_step(&g_app, g_b.now);
        const int f = h_frames(&g_b);
        CHECK(f >= 1);
        CHECK_EQ(g_frames[f - 1].h.type, STAC_MSG_INFO);
    }
}

TEST(fuzz_mutated_valid_frames) {
    fake_init(&g_b);
    fake_boot(&g_b, &g_app);
    uint32_t sent = 0;
    for (int round = 0; round < 3000; round++) {
        uint8_t payload[STAC_MAX_PAYLOAD];
        const size_t plen = rnd() % (STAC_CONFIGURE_SIZE + 4u);
        for (size_t i = 0; i < plen; i++) {
            payload[i] = (uint8_t)rnd();
        }
        uint8_t wire[STAC_MAX_FRAME];
        const uint8_t type = (uint8_t)(rnd() % 3u == 0u ? rnd() : 1u + rnd() % 8u);
        size_t w = stac_frame_encode_version((uint8_t)(rnd() % 8u == 0u ? rnd() : 1u), 0, type,
                                             (uint16_t)round, payload, plen, wire, sizeof wire);
        if (rnd() % 2u == 0u && w > 2u) {
            wire[rnd() % (w - 1u)] ^= (uint8_t)(1u << (rnd() % 8u)); /* may add a zero too */
        }
        if (rnd() % 4u == 0u && w > 3u) {
            w = 1u + rnd() % (w - 1u); /* truncated; the next frame's delimiter closes it */
        }
        fake_send_raw(&g_b, wire, w);
        sent++;
        if (round % 16 == 15) {
            stac_app_step(&g_app, g_b.now);
            g_b.now += 1000u;
            CHECK(h_frames(&g_b) >= 0);
            fake_clear_tx(&g_b);
        }
    }
    const stac_stats_t *s = &g_app.stats;
    /* Every frame was either served or counted: STOP/START toggled streaming on the way. */
    CHECK(s->rx_frames + s->rx_errors > 0u);
    CHECK(s->rx_frames + s->rx_errors <= sent);
    stac_app_step(&g_app, g_b.now);
}

const test_case_t g_fuzz_tests[] = {
    {"fuzz_random_bytes_then_recover", fuzz_random_bytes_then_recover},
    {"fuzz_mutated_valid_frames", fuzz_mutated_valid_frames},
    {NULL, NULL},
};
