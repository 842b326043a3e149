/* The platform-independent loop of the model check (model_check.h). */
#include "model_check.h"

#include <string.h>

#include "generated/stac_messages.h"
#include "stac_model.h"

static stac_model_t g_model;
static stac_model_state_t g_state;
static float g_ref_a[MC_REF_LEN], g_ref_b[MC_REF_LEN];
volatile float g_ref_sink; /* keeps the reference loop from being optimised away */

static uint32_t elapsed(uint32_t start, uint32_t end) { return (start - end) & 0xFFFFFFu; }

/* The reference of known cost: MC_REF_LEN float multiply-adds, the decoder's inner loop. */
__attribute__((noinline)) static float ref_dot(const float *a, const float *b, uint32_t n) {
    float acc = 0.0f;
    for (uint32_t i = 0; i < n; ++i) acc += a[i] * b[i];
    return acc;
}

int mc_run(const uint8_t *image, uint32_t size) {
    if (stac_model_open(&g_model, image, size) != STAC_OK) return 2;
    stac_model_reset(&g_model, &g_state);
    uint8_t in[MC_IN_SIZE];
    mc_record_t rec;
    while (mc_read(in, MC_IN_SIZE) == MC_IN_SIZE) {
        if (in[0] == MC_TARE_STEP) {
            stac_model_tare(&g_state);
            continue;
        }
        uint16_t counts[3][5];
        for (unsigned s = 0; s < 3u; ++s)
            for (unsigned c = 0; c < 5u; ++c) {
                const uint8_t *p = in + 4u + 2u * (5u * s + c);
                counts[s][c] = (uint16_t)(p[0] | (p[1] << 8));
            }
        stac_model_output_t out;
        memset(&out, 0, sizeof out);
        memset(&rec, 0, sizeof rec);
        const uint32_t t0 = mc_ticks();
        rec.ret = stac_model_push(&g_model, &g_state, in[0],
                                  (const uint16_t(*)[5])counts, in + 1, &out);
        rec.ticks = elapsed(t0, mc_ticks());
        rec.flags = out.flags;
        rec.region = out.region;
        memcpy(rec.force, out.force, sizeof rec.force);
        memcpy(rec.torque, out.torque, sizeof rec.torque);
        rec.region_prob = out.region_prob;
        rec.contact_prob = out.contact_prob;
        memcpy(rec.out, g_state.out, sizeof rec.out);
        mc_write((const uint8_t *)&rec, MC_OUT_SIZE);
    }
    memset(&rec, 0, sizeof rec);
    for (uint32_t i = 0; i < MC_REF_LEN; ++i) {
        g_ref_a[i] = (float)i * 0.001f;
        g_ref_b[i] = 1.0f - (float)i * 0.0005f;
    }
    const uint32_t t0 = mc_ticks();
    g_ref_sink = ref_dot(g_ref_a, g_ref_b, MC_REF_LEN);
    rec.ticks = elapsed(t0, mc_ticks());
    rec.ret = MC_TRAILER;
    rec.flags = mc_calibrate(MC_CALIB_ITERS);
    rec.region = MC_REF_LEN;
    mc_write((const uint8_t *)&rec, MC_OUT_SIZE);
    return 0;
}
