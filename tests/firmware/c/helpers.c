#include "helpers.h"

fake_frame_t g_frames[H_MAX_FRAMES];

int h_frames(const fake_board_t *b) {
    return fake_frames(b, g_frames, H_MAX_FRAMES);
}

void h_send_configure(fake_board_t *b, const stac_configure_t *c, uint16_t seq) {
    uint8_t p[STAC_CONFIGURE_SIZE];
    const size_t n = stac_configure_pack(c, p);
    fake_send(b, STAC_MSG_CONFIGURE, seq, p, n);
}

void h_send_empty(fake_board_t *b, uint8_t type, uint16_t seq) {
    fake_send(b, type, seq, (const uint8_t *)0, 0u);
}

int h_samples(int n, stac_sample_t *out, int cap) {
    int k = 0;
    for (int i = 0; i < n && i < H_MAX_FRAMES; i++) {
        if (g_frames[i].h.type == STAC_MSG_SAMPLE && k < cap) {
            stac_sample_unpack(&out[k++], g_frames[i].payload, g_frames[i].len);
        }
    }
    return k;
}
