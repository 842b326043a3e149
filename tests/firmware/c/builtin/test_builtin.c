/* A firmware built with a built-in model (-DSTAC_BUILTIN_MODEL and stac_builtin_model.c from
 * tools/firmware/builtin_model.py): it decodes without an upload, an uploaded model takes its
 * place, and MODEL_CLEAR (or a refused upload) brings it back. */
#include <string.h>

#include "check.h"
#include "helpers.h"
#include "stac_crc32c.h"

extern const uint8_t stac_builtin_model[];
extern const uint32_t stac_builtin_model_size;
extern const uint8_t test_model_image[];
extern const uint32_t test_model_image_size;

static fake_board_t g_b;
static stac_app_t g_app;
static uint16_t g_seq;

static int pass(void) {
    g_b.pass++;
    stac_app_step(&g_app, g_b.now);
    g_b.now += 100u;
    return h_frames(&g_b);
}

/* One command, one pass: the reply frame's type (0 without one). */
static uint8_t command(uint8_t type, const uint8_t *payload, size_t len) {
    fake_clear_tx(&g_b);
    fake_send(&g_b, type, ++g_seq, payload, len);
    return pass() < 1 ? 0u : g_frames[0].h.type;
}

static stac_model_info_t info(void) {
    stac_model_info_t m;
    memset(&m, 0, sizeof m);
    if (command(STAC_MSG_GET_MODEL, NULL, 0u) == STAC_MSG_MODEL_INFO) {
        stac_model_info_unpack(&m, g_frames[0].payload, g_frames[0].len);
    }
    return m;
}

static uint8_t upload(uint32_t model_id, uint32_t size) {
    const stac_model_begin_t b = {.model_id = model_id, .size = size,
                                  .crc = stac_crc32c(test_model_image, size)};
    uint8_t p[STAC_MODEL_CHUNK_SIZE];
    uint8_t rc = command(STAC_MSG_MODEL_BEGIN, p, stac_model_begin_pack(&b, p));
    for (uint32_t off = 0u; rc == STAC_MSG_ACK && off < size; off += 224u) {
        stac_model_chunk_t c;
        memset(&c, 0, sizeof c);
        c.offset = off;
        c.length = (uint8_t)(size - off < 224u ? size - off : 224u);
        memcpy(c.data, test_model_image + off, c.length);
        rc = command(STAC_MSG_MODEL_CHUNK, p, stac_model_chunk_pack(&c, p));
    }
    const stac_model_commit_t c = {.model_id = model_id};
    return rc == STAC_MSG_ACK ? command(STAC_MSG_MODEL_COMMIT, p, stac_model_commit_pack(&c, p))
                              : rc;
}

static uint32_t header_model_id(void) {
    return (uint32_t)stac_builtin_model[8] | ((uint32_t)stac_builtin_model[9] << 8) |
           ((uint32_t)stac_builtin_model[10] << 16) | ((uint32_t)stac_builtin_model[11] << 24);
}

TEST(builtin_model_is_used_without_an_upload) {
    fake_init(&g_b);
    fake_boot(&g_b, &g_app);
    const stac_model_info_t m = info();
    CHECK_EQ(m.present, STAC_STORE_BUILTIN);
    CHECK_EQ(m.model_id, header_model_id());
    CHECK_EQ(m.size, stac_builtin_model_size);
    CHECK_EQ(m.crc, stac_crc32c(stac_builtin_model, stac_builtin_model_size));
    CHECK_EQ(m.weight_format, STAC_MODEL_W_F16);
    /* Estimates come from it. */
    stac_configure_t c;
    stac_default_config(&c);
    c.flags = STAC_CONFIG_ESTIMATE | STAC_CONFIG_STREAM;
    h_send_configure(&g_b, &c, ++g_seq);
    fake_run_until(&g_b, &g_app, g_b.now + 500000u, 100u);
    const int n = h_frames(&g_b);
    const fake_frame_t *f = fake_last(g_frames, n, STAC_MSG_ESTIMATE);
    CHECK(f != NULL);
    stac_estimate_t e;
    stac_estimate_unpack(&e, f->payload, f->len);
    CHECK_EQ(e.model_id, header_model_id());
}

TEST(builtin_model_steps_aside_for_an_upload_and_returns) {
    fake_init(&g_b);
    fake_boot(&g_b, &g_app);
    CHECK_EQ(upload(0x5151u, test_model_image_size), STAC_MSG_ACK);
    stac_model_info_t m = info();
    CHECK_EQ(m.present, STAC_STORE_UPLOADED);
    CHECK_EQ(m.model_id, 0x5151u);
    fake_boot(&g_b, &g_app); /* reset: the upload is still preferred */
    CHECK_EQ(info().present, STAC_STORE_UPLOADED);
    CHECK_EQ(command(STAC_MSG_MODEL_CLEAR, NULL, 0u), STAC_MSG_ACK);
    m = info();
    CHECK_EQ(m.present, STAC_STORE_BUILTIN);
    CHECK_EQ(m.model_id, header_model_id());
    /* A refused upload leaves the built-in model in use. */
    CHECK_EQ(upload(0x5252u, test_model_image_size - 4u), STAC_MSG_NACK);
    CHECK_EQ(info().present, STAC_STORE_BUILTIN);
}

static const test_case_t k_tests[] = {
    {"builtin_model_is_used_without_an_upload", builtin_model_is_used_without_an_upload},
    {"builtin_model_steps_aside_for_an_upload_and_returns",
     builtin_model_steps_aside_for_an_upload_and_returns},
    {NULL, NULL},
};

int main(int argc, char **argv) {
    const test_case_t *const tables[] = {k_tests};
    return check_main(tables, 1u, argc > 1 ? argv[1] : NULL);
}
