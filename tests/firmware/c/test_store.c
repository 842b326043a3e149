/* Model store and on-device estimates: uploads through the command layer into the fake board's
 * flash, every NACK path, power cuts and flash faults at every step, survival across reboots,
 * ESTIMATE frames after their SAMPLE and ESTIMATE_ONLY. */
#include <string.h>

#include "check.h"
#include "helpers.h"
#include "stac_crc32c.h"

extern const uint8_t test_model_image[];
extern const uint32_t test_model_image_size;

#define NO_REPLY 0xFFFFu
#define IMAGE_CAP (FAKE_FLASH_SIZE - STAC_STORE_RECORD_AREA)
#define MAX_IMAGE 4096u

static fake_board_t g_b;
static stac_app_t g_app;
static uint16_t g_seq;
static uint8_t g_other[MAX_IMAGE]; /* a second valid image (another model_id) */

static void boot(void) {
    fake_init(&g_b);
    fake_boot(&g_b, &g_app);
    g_seq = 0u;
}

/* Power-cycle the device: the flash keeps what it holds, RAM starts over. */
static void reboot(void) {
    g_b.flash_dead = false;
    g_b.flash_power_cut = false;
    g_b.flash_fail_at = 0u;
    fake_clear_tx(&g_b);
    fake_boot(&g_b, &g_app);
}

static int pass(void) {
    g_b.pass++;
    stac_app_step(&g_app, g_b.now);
    g_b.now += 100u;
    return h_frames(&g_b);
}

/* Send one command and run a pass: STAC_OK for an ACK, the NACK's error, else NO_REPLY. */
static uint16_t command(uint8_t type, const uint8_t *payload, size_t len, uint8_t *field) {
    fake_clear_tx(&g_b);
    fake_send(&g_b, type, ++g_seq, payload, len);
    const int n = pass();
    for (int i = 0; i < n; i++) {
        if (g_frames[i].h.type == STAC_MSG_ACK) {
            return STAC_OK;
        }
        if (g_frames[i].h.type == STAC_MSG_NACK) {
            stac_nack_t m;
            stac_nack_unpack(&m, g_frames[i].payload, g_frames[i].len);
            if (field != NULL) {
                *field = m.field_index;
            }
            return m.error;
        }
    }
    return NO_REPLY;
}

static uint16_t begin(uint32_t model_id, uint32_t size, uint32_t crc) {
    const stac_model_begin_t m = {.model_id = model_id, .size = size, .crc = crc};
    uint8_t p[STAC_MODEL_BEGIN_SIZE];
    return command(STAC_MSG_MODEL_BEGIN, p, stac_model_begin_pack(&m, p), NULL);
}

static uint16_t chunk(uint32_t offset, const uint8_t *data, uint32_t len) {
    stac_model_chunk_t m;
    memset(&m, 0, sizeof m);
    m.offset = offset;
    m.length = (uint8_t)len;
    memcpy(m.data, data, len > sizeof m.data ? sizeof m.data : len);
    uint8_t p[STAC_MODEL_CHUNK_SIZE];
    return command(STAC_MSG_MODEL_CHUNK, p, stac_model_chunk_pack(&m, p), NULL);
}

static uint16_t commit(uint32_t model_id) {
    const stac_model_commit_t m = {.model_id = model_id};
    uint8_t p[STAC_MODEL_COMMIT_SIZE];
    return command(STAC_MSG_MODEL_COMMIT, p, stac_model_commit_pack(&m, p), NULL);
}

/* A whole upload in chunks of `step` bytes: the first error, or STAC_OK. */
static uint16_t upload(const uint8_t *image, uint32_t size, uint32_t model_id, uint32_t step) {
    uint16_t err = begin(model_id, size, stac_crc32c(image, size));
    for (uint32_t off = 0u; err == STAC_OK && off < size; off += step) {
        err = chunk(off, image + off, size - off < step ? size - off : step);
    }
    return err == STAC_OK ? commit(model_id) : err;
}

static stac_model_info_t model_info(void) {
    stac_model_info_t m;
    memset(&m, 0xEE, sizeof m);
    fake_clear_tx(&g_b);
    h_send_empty(&g_b, STAC_MSG_GET_MODEL, ++g_seq);
    const int n = pass();
    const fake_frame_t *f = fake_last(g_frames, n, STAC_MSG_MODEL_INFO);
    if (f != NULL) {
        stac_model_info_unpack(&m, f->payload, f->len);
    }
    return m;
}

/* The fixture with another model_id in its header and its trailing CRC-32C redone. */
static void make_other_image(void) {
    const uint32_t n = test_model_image_size;
    memcpy(g_other, test_model_image, n);
    g_other[8] ^= 0x5Au; /* model_id, header bytes 8..11 */
    const uint32_t crc = stac_crc32c(g_other, n - 4u);
    for (uint32_t i = 0u; i < 4u; i++) {
        g_other[n - 4u + i] = (uint8_t)(crc >> (8u * i));
    }
}

TEST(store_fixture_fits) {
    CHECK(test_model_image_size > 0u && test_model_image_size <= MAX_IMAGE);
    CHECK(test_model_image_size <= IMAGE_CAP);
}

TEST(store_empty_reports_capacity_and_limits) {
    boot();
    const stac_model_info_t m = model_info();
    CHECK_EQ(m.present, STAC_STORE_NONE);
    CHECK_EQ(m.model_id, 0);
    CHECK_EQ(m.size, 0);
    CHECK_EQ(m.capacity, IMAGE_CAP);
    CHECK_EQ(m.max_inputs, STAC_MODEL_MAX_INPUTS);
    CHECK_EQ(m.max_hidden, STAC_MODEL_MAX_HIDDEN);
}

TEST(store_upload_commit_and_info) {
    boot();
    const uint32_t n = test_model_image_size;
    CHECK_EQ(upload(test_model_image, n, 0x1234u, 100u), STAC_OK);
    const stac_model_info_t m = model_info();
    CHECK_EQ(m.present, STAC_STORE_UPLOADED);
    CHECK_EQ(m.model_id, 0x1234u);
    CHECK_EQ(m.size, n);
    CHECK_EQ(m.crc, stac_crc32c(test_model_image, n));
    CHECK_EQ(m.weight_format, STAC_MODEL_W_F32);
    CHECK_EQ(m.led_steps, 1);
    CHECK_EQ(m.n_inputs, 12);
    CHECK(memcmp(g_b.flash, test_model_image, n) == 0);
    CHECK_EQ(g_app.stats.command_errors, 0);
}

TEST(store_any_chunk_length_lands_in_flash) {
    static const uint32_t steps[] = {1u, 3u, 7u, 224u, 223u};
    for (size_t k = 0u; k < sizeof steps / sizeof steps[0]; k++) {
        boot();
        CHECK_EQ(upload(test_model_image, test_model_image_size, 7u, steps[k]), STAC_OK);
        CHECK(memcmp(g_b.flash, test_model_image, test_model_image_size) == 0);
        CHECK_EQ(model_info().present, STAC_STORE_UPLOADED);
    }
}

TEST(store_model_survives_reboot_and_clear_removes_it) {
    boot();
    CHECK_EQ(upload(test_model_image, test_model_image_size, 99u, 224u), STAC_OK);
    reboot();
    stac_model_info_t m = model_info();
    CHECK_EQ(m.present, STAC_STORE_UPLOADED);
    CHECK_EQ(m.model_id, 99);
    CHECK_EQ(command(STAC_MSG_MODEL_CLEAR, NULL, 0u, NULL), STAC_OK);
    CHECK_EQ(model_info().present, STAC_STORE_NONE);
    reboot();
    m = model_info();
    CHECK_EQ(m.present, STAC_STORE_NONE);
    CHECK_EQ(m.model_id, 0);
    /* Clearing an empty store is fine too. */
    CHECK_EQ(command(STAC_MSG_MODEL_CLEAR, NULL, 0u, NULL), STAC_OK);
}

TEST(store_begin_rejects_sizes) {
    boot();
    CHECK_EQ(begin(1u, IMAGE_CAP + 1u, 0u), STAC_MODEL_TOO_LARGE);
    CHECK_EQ(begin(1u, 0xFFFFFFFFu, 0u), STAC_MODEL_TOO_LARGE);
    CHECK_EQ(begin(1u, 0u, 0u), STAC_MODEL_INVALID);
    /* No upload is in progress after a refused MODEL_BEGIN. */
    CHECK_EQ(chunk(0u, test_model_image, 4u), STAC_MODEL_BAD_CHUNK);
    /* The largest size is accepted. */
    CHECK_EQ(begin(1u, IMAGE_CAP, 0u), STAC_OK);
}

/* MODEL_BEGIN of `size` bytes on flash that holds old data everywhere: which sectors it
 * erased (bit k: sector k; each erased whole and at most once, the others keep the old
 * data) and in how many erase operations. */
typedef struct {
    uint32_t sectors, ops;
} begin_erase_t;

static begin_erase_t begin_on_old_data(uint32_t size) {
    boot();
    memset(g_b.flash, 0x5A, sizeof g_b.flash);
    const uint32_t ops = g_b.flash_erases;
    begin_erase_t r = {0u, 0u};
    if (begin(1u, size, 0u) != STAC_OK) {
        r.ops = 0xFFFFFFFFu;
        return r;
    }
    r.ops = g_b.flash_erases - ops;
    for (uint32_t k = 0u; k < FAKE_FLASH_SECTORS; k++) {
        const uint32_t lo = fake_flash_sector_start[k], hi = fake_flash_sector_start[k + 1u];
        const uint8_t expect = g_b.sector_erases[k] > 0u ? 0xFFu : 0x5Au;
        for (uint32_t i = lo; i < hi; i++) {
            if (g_b.flash[i] != expect) {
                r.ops = 0xFFFFFFFEu;
            }
        }
        r.sectors |= g_b.sector_erases[k] == 1u ? 1u << k : 0u;
        r.sectors |= g_b.sector_erases[k] > 1u ? 0x100u << k : 0u; /* erased twice */
    }
    return r;
}

#define CHECK_BEGIN_ERASES(size, sectors_, ops_)      \
    do {                                              \
        const begin_erase_t got_ = begin_on_old_data(size); \
        CHECK_EQ(got_.sectors, sectors_);             \
        CHECK_EQ(got_.ops, ops_);                     \
    } while (0)

/* MODEL_BEGIN erases the sectors under [0, size) and the record's (last) sector, nothing
 * else; an image reaching into the last sector takes the record along in one erase. */
TEST(store_begin_erases_only_the_sectors_the_image_needs) {
    CHECK_BEGIN_ERASES(test_model_image_size, 0x9u, 2u); /* sector 0, the record's 3 */
    CHECK_BEGIN_ERASES(4096u, 0x9u, 2u);                 /* exactly sector 0 */
    CHECK_BEGIN_ERASES(4097u, 0xBu, 2u);                 /* one word into sector 1 */
    CHECK_BEGIN_ERASES(16384u, 0xFu, 2u);                /* sectors 0-2, then the record's */
    CHECK_BEGIN_ERASES(16385u, 0xFu, 1u);                /* the record went with the image */
    CHECK_BEGIN_ERASES(IMAGE_CAP, 0xFu, 1u);
    /* Whatever the old bytes past the image were, the small image uploads and validates. */
    boot();
    memset(g_b.flash, 0x5A, sizeof g_b.flash);
    CHECK_EQ(upload(test_model_image, test_model_image_size, 3u, 224u), STAC_OK);
    reboot();
    CHECK_EQ(model_info().present, STAC_STORE_UPLOADED);
    CHECK_EQ(g_b.flash[fake_flash_sector_start[1]], 0x5Au);
    /* MODEL_CLEAR erases the whole region. */
    CHECK_EQ(command(STAC_MSG_MODEL_CLEAR, NULL, 0u, NULL), STAC_OK);
    for (uint32_t i = 0u; i < FAKE_FLASH_SIZE; i++) {
        CHECK_EQ(g_b.flash[i], 0xFFu);
    }
}

TEST(store_begin_invalidates_at_once) {
    boot();
    CHECK_EQ(upload(test_model_image, test_model_image_size, 5u, 224u), STAC_OK);
    CHECK_EQ(begin(6u, 100u, 0u), STAC_OK);
    CHECK_EQ(model_info().present, STAC_STORE_NONE);
    reboot();
    CHECK_EQ(model_info().present, STAC_STORE_NONE);
}

/* SPEC: a NACKed command changes nothing. A MODEL_BEGIN refused for its size leaves the
 * installed model in use (and in flash, across a reboot) and an upload in progress open. */
TEST(store_refused_begin_changes_nothing) {
    boot();
    CHECK_EQ(upload(test_model_image, test_model_image_size, 5u, 224u), STAC_OK);
    const uint32_t erases = g_b.flash_erases, programs = g_b.flash_programs;
    CHECK_EQ(begin(6u, IMAGE_CAP + 1u, 0u), STAC_MODEL_TOO_LARGE);
    CHECK_EQ(begin(6u, 0xFFFFFFFFu, 0u), STAC_MODEL_TOO_LARGE);
    CHECK_EQ(begin(6u, 0u, 0u), STAC_MODEL_INVALID);
    CHECK_EQ(g_b.flash_erases, erases);
    CHECK_EQ(g_b.flash_programs, programs);
    stac_model_info_t m = model_info();
    CHECK_EQ(m.present, STAC_STORE_UPLOADED);
    CHECK_EQ(m.model_id, 5u);
    reboot();
    m = model_info();
    CHECK_EQ(m.present, STAC_STORE_UPLOADED);
    CHECK_EQ(m.model_id, 5u);
    /* An upload in progress survives a refused MODEL_BEGIN too. */
    const uint8_t *img = test_model_image;
    const uint32_t n = test_model_image_size;
    CHECK_EQ(begin(7u, n, stac_crc32c(img, n)), STAC_OK);
    CHECK_EQ(chunk(0u, img, 100u), STAC_OK);
    CHECK_EQ(begin(8u, IMAGE_CAP + 1u, 0u), STAC_MODEL_TOO_LARGE);
    for (uint32_t off = 100u; off < n; off += 224u) {
        CHECK_EQ(chunk(off, img + off, n - off < 224u ? n - off : 224u), STAC_OK);
    }
    CHECK_EQ(commit(7u), STAC_OK);
    CHECK_EQ(model_info().model_id, 7u);
}

/* Every refused chunk ends the upload (SPEC section 13): the right chunk after it is refused
 * too, until a new MODEL_BEGIN. */
static uint16_t refused_then_next(uint32_t bad_off, const uint8_t *bad, uint32_t bad_len,
                                  uint32_t good_off, uint32_t good_len) {
    const uint16_t err = chunk(bad_off, bad, bad_len);
    if (err != STAC_MODEL_BAD_CHUNK) {
        return err;
    }
    return chunk(good_off, test_model_image + good_off, good_len);
}

/* A fresh upload of the fixture with its first `bytes` bytes already sent. */
static uint16_t restart(uint32_t bytes) {
    const uint32_t n = test_model_image_size;
    uint16_t err = begin(3u, n, stac_crc32c(test_model_image, n));
    for (uint32_t off = 0u; err == STAC_OK && off < bytes; off += 200u) {
        err = chunk(off, test_model_image + off, bytes - off < 200u ? bytes - off : 200u);
    }
    return err;
}

TEST(store_chunks_out_of_order_duplicate_or_past_the_end) {
    boot();
    const uint8_t *img = test_model_image;
    const uint32_t n = test_model_image_size;
    CHECK_EQ(chunk(0u, img, 16u), STAC_MODEL_BAD_CHUNK); /* no MODEL_BEGIN */
    CHECK_EQ(restart(0u), STAC_OK);
    CHECK_EQ(refused_then_next(16u, img + 16u, 16u, 0u, 16u), STAC_MODEL_BAD_CHUNK); /* gap */
    CHECK_EQ(restart(16u), STAC_OK);
    CHECK_EQ(refused_then_next(0u, img, 16u, 16u, 16u), STAC_MODEL_BAD_CHUNK); /* duplicate */
    CHECK_EQ(restart(16u), STAC_OK);
    CHECK_EQ(refused_then_next(8u, img + 8u, 16u, 16u, 16u), STAC_MODEL_BAD_CHUNK); /* overlap */
    uint8_t field = 0u;
    stac_model_chunk_t m;
    memset(&m, 0, sizeof m);
    m.offset = 16u;
    m.length = 0u;
    uint8_t p[STAC_MODEL_CHUNK_SIZE];
    CHECK_EQ(restart(16u), STAC_OK);
    CHECK_EQ(command(STAC_MSG_MODEL_CHUNK, p, stac_model_chunk_pack(&m, p), &field),
             STAC_MODEL_BAD_CHUNK);
    CHECK_EQ(field, 1); /* length */
    CHECK_EQ(chunk(16u, img + 16u, 16u), STAC_MODEL_BAD_CHUNK);
    CHECK_EQ(restart(16u), STAC_OK);
    m.length = 225u;
    CHECK_EQ(command(STAC_MSG_MODEL_CHUNK, p, stac_model_chunk_pack(&m, p), &field),
             STAC_MODEL_BAD_CHUNK);
    CHECK_EQ(field, 1);
    CHECK_EQ(chunk(16u, img + 16u, 16u), STAC_MODEL_BAD_CHUNK);
    /* Past the size: refused, and the upload is over even for the right last chunk. */
    CHECK_EQ(restart(n - 10u), STAC_OK);
    uint8_t tail[11] = {0u};
    memcpy(tail, img + n - 10u, 10u);
    CHECK_EQ(refused_then_next(n - 10u, tail, 11u, n - 10u, 10u), STAC_MODEL_BAD_CHUNK);
    CHECK_EQ(commit(3u), STAC_MODEL_BAD_CHUNK); /* no upload left to commit */
    CHECK_EQ(model_info().present, STAC_STORE_NONE);
    /* Restarted and sent in order, it commits. */
    CHECK_EQ(restart(n - 10u), STAC_OK);
    CHECK_EQ(chunk(n - 10u, img + n - 10u, 10u), STAC_OK);
    CHECK_EQ(chunk(n, img, 1u), STAC_MODEL_BAD_CHUNK); /* past the end ends it too */
    CHECK_EQ(commit(3u), STAC_MODEL_BAD_CHUNK);
    CHECK_EQ(upload(img, n, 3u, 224u), STAC_OK);
    CHECK_EQ(model_info().present, STAC_STORE_UPLOADED);
}

TEST(store_commit_refusals_leave_no_model) {
    const uint8_t *img = test_model_image;
    const uint32_t n = test_model_image_size;
    boot();
    CHECK_EQ(commit(1u), STAC_MODEL_BAD_CHUNK); /* nothing to commit */
    /* Short of the announced size. */
    CHECK_EQ(begin(1u, n, stac_crc32c(img, n)), STAC_OK);
    CHECK_EQ(chunk(0u, img, 200u), STAC_OK);
    CHECK_EQ(commit(1u), STAC_MODEL_BAD_CRC);
    CHECK_EQ(commit(1u), STAC_MODEL_BAD_CHUNK); /* the refused commit ended the upload */
    /* Another model_id than MODEL_BEGIN's: MODEL_BAD_CRC (SPEC), and the upload is over. */
    CHECK_EQ(begin(1u, n, stac_crc32c(img, n)), STAC_OK);
    for (uint32_t off = 0u; off < n; off += 224u) {
        CHECK_EQ(chunk(off, img + off, n - off < 224u ? n - off : 224u), STAC_OK);
    }
    CHECK_EQ(commit(2u), STAC_MODEL_BAD_CRC);
    CHECK_EQ(commit(1u), STAC_MODEL_BAD_CHUNK);
    CHECK_EQ(model_info().present, STAC_STORE_NONE);
    /* MODEL_BEGIN announced another CRC. */
    CHECK_EQ(begin(1u, n, stac_crc32c(img, n) ^ 1u), STAC_OK);
    for (uint32_t off = 0u; off < n; off += 224u) {
        CHECK_EQ(chunk(off, img + off, n - off < 224u ? n - off : 224u), STAC_OK);
    }
    CHECK_EQ(commit(1u), STAC_MODEL_BAD_CRC);
    CHECK_EQ(model_info().present, STAC_STORE_NONE);
    /* Bytes that match their CRC but are no model the interpreter accepts. */
    static uint8_t bad[MAX_IMAGE];
    memcpy(bad, img, n);
    bad[n / 2u] ^= 0x40u; /* the image's own CRC no longer matches */
    CHECK_EQ(upload(bad, n, 1u, 224u), STAC_MODEL_INVALID);
    CHECK_EQ(model_info().present, STAC_STORE_NONE);
    CHECK_EQ(upload(img, n - 4u, 1u, 224u), STAC_MODEL_INVALID); /* truncated */
    CHECK_EQ(model_info().present, STAC_STORE_NONE);
    reboot();
    CHECK_EQ(model_info().present, STAC_STORE_NONE);
    CHECK_EQ(upload(img, n, 1u, 224u), STAC_OK); /* the store still works */
}

/* Cut the power after every word the upload programs (and before the first): after the
 * reboot the store holds the old model only if nothing was written yet, the new one only if
 * its upload finished, and otherwise none - never a half model. */
TEST(store_power_cut_at_every_word_never_leaves_a_half_model) {
    make_other_image();
    const uint32_t n = test_model_image_size;
    const uint32_t crc_old = stac_crc32c(test_model_image, n);
    const uint32_t crc_new = stac_crc32c(g_other, n);
    /* Words one upload programs: the record kill, the image, the record. */
    const uint32_t total = 1u + (n + 3u) / 4u + 5u;
    uint32_t saw_none = 0u;
    for (uint32_t cut = 0u; cut <= total; cut++) {
        boot();
        if (upload(test_model_image, n, 10u, 224u) != STAC_OK) {
            CHECK(0);
        }
        g_b.flash_power_cut = true;
        g_b.flash_cut_words = cut;
        const uint16_t err = upload(g_other, n, 20u, 97u);
        reboot();
        const stac_model_info_t m = model_info();
        if (cut == total) {
            CHECK_EQ(err, STAC_OK);
        }
        if (m.present == STAC_STORE_NONE) {
            saw_none++;
            CHECK(err != STAC_OK);
        } else {
            CHECK_EQ(m.present, STAC_STORE_UPLOADED);
            if (m.model_id == 10u) {
                CHECK_EQ(cut, 0);
                CHECK_EQ(m.crc, crc_old);
            } else {
                CHECK_EQ(m.model_id, 20u);
                CHECK_EQ(cut, total);
                CHECK_EQ(m.crc, crc_new);
            }
        }
    }
    CHECK_EQ(saw_none, total - 1u);
}

/* Reset between any two commands of an upload: the store comes back empty. */
TEST(store_reset_between_commands_never_leaves_a_model) {
    const uint32_t n = test_model_image_size;
    const uint32_t chunks = (n + 223u) / 224u;
    for (uint32_t stop = 0u; stop <= chunks; stop++) {
        boot();
        CHECK_EQ(begin(4u, n, stac_crc32c(test_model_image, n)), STAC_OK);
        for (uint32_t c = 0u; c < stop && c < chunks; c++) {
            const uint32_t off = c * 224u;
            CHECK_EQ(chunk(off, test_model_image + off, n - off < 224u ? n - off : 224u),
                     STAC_OK);
        }
        reboot();
        CHECK_EQ(model_info().present, STAC_STORE_NONE);
        /* The upload did not survive the reset either. */
        CHECK_EQ(commit(4u), STAC_MODEL_BAD_CHUNK);
    }
}

/* Make each flash operation of an upload fail in turn: FLASH_ERROR, and no model, neither
 * now nor after a reboot. */
TEST(store_flash_failure_at_every_operation_is_flash_error) {
    const uint32_t n = test_model_image_size;
    boot();
    CHECK_EQ(upload(test_model_image, n, 1u, 224u), STAC_OK);
    const uint32_t ops = g_b.flash_erases + g_b.flash_programs;
    CHECK(ops > 3u);
    for (uint32_t k = 1u; k <= ops; k++) {
        boot();
        g_b.flash_fail_at = k;
        CHECK_EQ(upload(test_model_image, n, 1u, 224u), STAC_FLASH_ERROR);
        CHECK_EQ(model_info().present, STAC_STORE_NONE);
        reboot();
        CHECK_EQ(model_info().present, STAC_STORE_NONE);
    }
    /* The clear of a working store is acknowledged even if its erase fails (the record kill
     * already ended the model); if both fail the model stays and the NACK says so. */
    boot();
    CHECK_EQ(upload(test_model_image, n, 1u, 224u), STAC_OK);
    g_b.flash_fail_at = g_b.flash_erases + g_b.flash_programs + 2u;
    CHECK_EQ(command(STAC_MSG_MODEL_CLEAR, NULL, 0u, NULL), STAC_OK);
    CHECK_EQ(model_info().present, STAC_STORE_NONE);
    boot();
    CHECK_EQ(upload(test_model_image, n, 1u, 224u), STAC_OK);
    g_b.flash_fail_at = g_b.flash_erases + g_b.flash_programs + 1u;
    CHECK_EQ(command(STAC_MSG_MODEL_CLEAR, NULL, 0u, NULL), STAC_FLASH_ERROR);
    CHECK_EQ(model_info().present, STAC_STORE_UPLOADED);
}

TEST(store_damaged_flash_is_not_used_at_boot) {
    const uint32_t n = test_model_image_size;
    boot();
    CHECK_EQ(upload(test_model_image, n, 1u, 224u), STAC_OK);
    g_b.flash[n / 3u] ^= 0x10u; /* a bit flipped in the image */
    reboot();
    CHECK_EQ(model_info().present, STAC_STORE_NONE);
    boot();
    CHECK_EQ(upload(test_model_image, n, 1u, 224u), STAC_OK);
    g_b.flash[IMAGE_CAP + 4u] = 0x00u; /* the record's size */
    reboot();
    CHECK_EQ(model_info().present, STAC_STORE_NONE);
}

static stac_configure_t estimate_config(uint8_t flags) {
    stac_configure_t c;
    stac_default_config(&c);
    c.integration_ms = 50u;
    c.flags = flags;
    return c;
}

TEST(store_configure_estimate_needs_a_matching_model) {
    boot();
    stac_configure_t c = estimate_config(STAC_CONFIG_ESTIMATE);
    uint8_t p[STAC_CONFIGURE_SIZE];
    uint8_t field = 0u;
    CHECK_EQ(command(STAC_MSG_CONFIGURE, p, stac_configure_pack(&c, p), &field), STAC_NO_MODEL);
    CHECK_EQ(field, 4); /* flags */
    /* ESTIMATE_ONLY without ESTIMATE asks for nothing: accepted, samples flow. */
    c.flags = STAC_CONFIG_ESTIMATE_ONLY;
    CHECK_EQ(command(STAC_MSG_CONFIGURE, p, stac_configure_pack(&c, p), NULL), STAC_OK);
    CHECK_EQ(upload(test_model_image, test_model_image_size, 8u, 224u), STAC_OK);
    c.flags = STAC_CONFIG_ESTIMATE;
    c.led_step_count = 2u;
    CHECK_EQ(command(STAC_MSG_CONFIGURE, p, stac_configure_pack(&c, p), &field),
             STAC_MODEL_MISMATCH);
    CHECK_EQ(field, 6); /* led_step_count */
    c.led_step_count = 1u;
    CHECK_EQ(command(STAC_MSG_CONFIGURE, p, stac_configure_pack(&c, p), NULL), STAC_OK);
}

/* Stream for `us` with the given flags; frames captured in g_frames, count returned. */
static int stream(uint8_t flags, uint32_t us) {
    const stac_configure_t c = estimate_config((uint8_t)(flags | STAC_CONFIG_STREAM));
    uint8_t p[STAC_CONFIGURE_SIZE];
    if (command(STAC_MSG_CONFIGURE, p, stac_configure_pack(&c, p), NULL) != STAC_OK) {
        return -1;
    }
    fake_clear_tx(&g_b);
    fake_run_until(&g_b, &g_app, g_b.now + us, 100u);
    return h_frames(&g_b);
}

TEST(store_estimate_follows_its_sample) {
    boot();
    CHECK_EQ(upload(test_model_image, test_model_image_size, 0xABCDu, 224u), STAC_OK);
    const int n = stream(STAC_CONFIG_ESTIMATE, 1000000u);
    CHECK(n > 10);
    int estimates = 0;
    for (int i = 0; i < n; i++) {
        if (g_frames[i].h.type != STAC_MSG_ESTIMATE) {
            continue;
        }
        estimates++;
        /* Right after the SAMPLE it decodes, which it names. */
        CHECK(i > 0 && g_frames[i - 1].h.type == STAC_MSG_SAMPLE);
        stac_sample_t s;
        stac_sample_unpack(&s, g_frames[i - 1].payload, g_frames[i - 1].len);
        stac_estimate_t e;
        stac_estimate_unpack(&e, g_frames[i].payload, g_frames[i].len);
        CHECK_EQ(e.sample_seq, s.sample_seq);
        CHECK_EQ(e.t_end_us, s.t_end_us);
        CHECK_EQ(e.config_id, s.config_id);
        CHECK_EQ(e.model_id, 0xABCDu);
        CHECK_EQ(e.flags & ~0x0Fu, 0);
        CHECK(e.region == 0u); /* the fixture has no region head */
        CHECK(e.torque[0] != e.torque[0]); /* NaN: the fixture decodes Fz only */
        CHECK((e.flags & STAC_EST_INVALID) != 0u || e.force[2] == e.force[2]);
    }
    CHECK(estimates > 10);
    CHECK_EQ(estimates, fake_count(g_frames, n, STAC_MSG_SAMPLE));
}

TEST(store_estimate_only_suppresses_samples) {
    boot();
    CHECK_EQ(upload(test_model_image, test_model_image_size, 77u, 224u), STAC_OK);
    const uint32_t taken = g_app.stats.samples_taken;
    const int n = stream(STAC_CONFIG_ESTIMATE | STAC_CONFIG_ESTIMATE_ONLY, 1000000u);
    CHECK_EQ(fake_count(g_frames, n, STAC_MSG_SAMPLE), 0);
    const int estimates = fake_count(g_frames, n, STAC_MSG_ESTIMATE);
    CHECK(estimates > 10);
    CHECK_EQ(g_app.stats.samples_taken - taken, (uint32_t)estimates); /* still counted */
    uint32_t next = 0u;
    for (int i = 0; i < n; i++) {
        if (g_frames[i].h.type == STAC_MSG_ESTIMATE) {
            stac_estimate_t e;
            stac_estimate_unpack(&e, g_frames[i].payload, g_frames[i].len);
            CHECK_EQ(e.sample_seq, next);
            next++;
        }
    }
    /* Without a model (cleared while streaming) the samples come back instead of silence. */
    CHECK_EQ(command(STAC_MSG_MODEL_CLEAR, NULL, 0u, NULL), STAC_OK);
    fake_clear_tx(&g_b);
    fake_run_until(&g_b, &g_app, g_b.now + 300000u, 100u);
    const int m = h_frames(&g_b);
    CHECK(fake_count(g_frames, m, STAC_MSG_SAMPLE) > 2);
    CHECK_EQ(fake_count(g_frames, m, STAC_MSG_ESTIMATE), 0);
}

TEST(store_estimates_restart_with_sample_seq_after_start) {
    boot();
    CHECK_EQ(upload(test_model_image, test_model_image_size, 5u, 224u), STAC_OK);
    int n = stream(STAC_CONFIG_ESTIMATE, 400000u);
    CHECK(fake_count(g_frames, n, STAC_MSG_ESTIMATE) > 2);
    CHECK_EQ(command(STAC_MSG_STOP, NULL, 0u, NULL), STAC_OK);
    CHECK_EQ(command(STAC_MSG_START, NULL, 0u, NULL), STAC_OK);
    fake_clear_tx(&g_b);
    fake_run_until(&g_b, &g_app, g_b.now + 400000u, 100u);
    n = h_frames(&g_b);
    const fake_frame_t *first = NULL;
    for (int i = 0; i < n && first == NULL; i++) {
        if (g_frames[i].h.type == STAC_MSG_ESTIMATE) {
            first = &g_frames[i];
        }
    }
    CHECK(first != NULL);
    stac_estimate_t e;
    stac_estimate_unpack(&e, first->payload, first->len);
    CHECK_EQ(e.sample_seq, 0);
}

static uint32_t trailer_crc(const uint8_t *image, uint32_t size) {
    const uint8_t *p = image + size - 4u;
    return (uint32_t)p[0] | ((uint32_t)p[1] << 8) | ((uint32_t)p[2] << 16) |
           ((uint32_t)p[3] << 24);
}

/* MODEL_INFO.image_crc is the image's own CRC, so two models give two values the host can
 * compare with its file; crc stays the transfer check, the same residue for both. */
TEST(store_model_info_reports_the_image_crc) {
    make_other_image();
    const uint32_t n = test_model_image_size;
    boot();
    CHECK_EQ(model_info().image_crc, 0u);
    CHECK_EQ(upload(test_model_image, n, 1u, 224u), STAC_OK);
    const stac_model_info_t a = model_info();
    CHECK_EQ(upload(g_other, n, 2u, 224u), STAC_OK);
    const stac_model_info_t b = model_info();
    CHECK_EQ(a.image_crc, trailer_crc(test_model_image, n));
    CHECK_EQ(b.image_crc, trailer_crc(g_other, n));
    CHECK(a.image_crc != b.image_crc);
    CHECK_EQ(a.image_crc, stac_crc32c(test_model_image, n - 4u));
    CHECK_EQ(a.crc, b.crc); /* CRC-32C of an image with its own CRC: always the residue */
    reboot();
    CHECK_EQ(model_info().image_crc, b.image_crc);
}

/* A synthetic image of `size` bytes whose own trailing CRC checks (no model: the header is
 * not STMI), in the fake flash as if uploaded; MODEL_BEGIN's crc is its whole CRC. */
static uint32_t fill_crc_image(uint32_t size) {
    for (uint32_t i = 0u; i + 4u < size; i++) {
        g_b.flash[i] = (uint8_t)(i * 7u);
    }
    const uint32_t body = stac_crc32c(g_b.flash, size - 4u);
    for (uint32_t i = 0u; i < 4u; i++) {
        g_b.flash[size - 4u + i] = (uint8_t)(body >> (8u * i));
    }
    return stac_crc32c(g_b.flash, size);
}

/* MODEL_COMMIT and boot make one CRC pass over the image, refreshing the watchdog after every
 * STAC_STORE_CRC_BLOCK bytes of it (and once after the interpreter's checks): the longest
 * stretch without a refresh is one block, whatever the image size. */
TEST(store_commit_and_boot_refresh_the_watchdog_once_per_block) {
    const uint32_t size = IMAGE_CAP - 100u; /* several blocks, not a whole number of them */
    const uint32_t blocks = (size - 4u + STAC_STORE_CRC_BLOCK - 1u) / STAC_STORE_CRC_BLOCK;
    CHECK(blocks >= 3u);
    boot();
    CHECK_EQ(begin(9u, size, 0u), STAC_OK);
    const uint32_t crc = fill_crc_image(size);
    /* Take the bytes as received: feed the upload state what a full transfer leaves. */
    g_app.store.up_crc = crc;
    g_app.store.received = size;
    uint32_t before = g_b.watchdog_refreshes;
    CHECK_EQ(commit(9u), STAC_MODEL_INVALID); /* CRC good, no STMI model: the pass ran whole */
    CHECK_EQ(g_b.watchdog_refreshes - before, blocks + 1u);
    /* A real model: one pass again (the interpreter reuses its CRC), and at boot the same. */
    const uint32_t n = test_model_image_size;
    const uint32_t model_blocks = (n - 4u + STAC_STORE_CRC_BLOCK - 1u) / STAC_STORE_CRC_BLOCK;
    before = g_b.watchdog_refreshes;
    CHECK_EQ(upload(test_model_image, n, 10u, 224u), STAC_OK);
    CHECK_EQ(g_b.watchdog_refreshes - before, model_blocks + 1u);
    before = g_b.watchdog_refreshes;
    reboot();
    CHECK_EQ(g_b.watchdog_refreshes - before, model_blocks + 1u);
    CHECK_EQ(model_info().model_id, 10u);
}

/* The decode of sample k runs after the integration of sample k + 1 was triggered: the
 * ESTIMATE goes out with one more trigger behind it than its SAMPLE, so decoding overlaps the
 * sensors' integration instead of delaying the next one. */
TEST(store_decode_runs_after_the_next_trigger) {
    boot();
    CHECK_EQ(upload(test_model_image, test_model_image_size, 0x77u, 224u), STAC_OK);
    const int n = stream(STAC_CONFIG_ESTIMATE, 1000000u);
    int checked = 0;
    for (int i = 0; i < n && i < 1024; i++) {
        if (g_frames[i].h.type != STAC_MSG_ESTIMATE) {
            continue;
        }
        CHECK(i > 0 && g_frames[i - 1].h.type == STAC_MSG_SAMPLE);
        CHECK_EQ(g_b.tx_triggers[i], g_b.tx_triggers[i - 1] + 1u);
        CHECK_EQ(g_b.tx_pass[i], g_b.tx_pass[i - 1]); /* still in the pass of its SAMPLE */
        checked++;
    }
    CHECK(checked > 10);
    /* STOP: the last SAMPLE's ESTIMATE is still sent, before the STOP's ACK. */
    fake_clear_tx(&g_b);
    fake_send(&g_b, STAC_MSG_STOP, ++g_seq, NULL, 0u);
    const int m = pass();
    CHECK(m >= 1);
    CHECK_EQ(g_frames[m - 1].h.type, STAC_MSG_ACK);
}

/* STATUS reports the HAL's cycle counter: its rate and the last and largest acquisition
 * (per sample) and decode; RESET_STATS clears them. */
TEST(store_status_reports_cycle_counts) {
    boot();
    CHECK_EQ(upload(test_model_image, test_model_image_size, 0x78u, 224u), STAC_OK);
    CHECK(stream(STAC_CONFIG_ESTIMATE, 300000u) > 4);
    fake_clear_tx(&g_b);
    h_send_empty(&g_b, STAC_MSG_GET_STATUS, ++g_seq);
    int n = pass();
    const fake_frame_t *f = fake_last(g_frames, n, STAC_MSG_STATUS);
    CHECK(f != NULL);
    stac_status_t s;
    stac_status_unpack(&s, f->payload, f->len);
    CHECK_EQ(s.cycle_hz, FAKE_CYCLE_HZ);
    /* Each span reads the counter twice or more: whole multiples of the fake's step. */
    CHECK(s.acq_cycles_last >= FAKE_CYCLES_PER_READ);
    CHECK(s.acq_cycles_max >= s.acq_cycles_last);
    CHECK_EQ(s.decode_cycles_last, FAKE_CYCLES_PER_READ);
    CHECK_EQ(s.decode_cycles_max, FAKE_CYCLES_PER_READ);
    CHECK_EQ(command(STAC_MSG_RESET_STATS, NULL, 0u, NULL), STAC_OK);
    CHECK_EQ(command(STAC_MSG_STOP, NULL, 0u, NULL), STAC_OK);
    fake_clear_tx(&g_b);
    h_send_empty(&g_b, STAC_MSG_GET_STATUS, ++g_seq);
    n = pass();
    f = fake_last(g_frames, n, STAC_MSG_STATUS);
    CHECK(f != NULL);
    stac_status_unpack(&s, f->payload, f->len);
    CHECK_EQ(s.decode_cycles_max, 0u);
    /* Without a cycle counter the device says so: 0 Hz, nothing measured. */
    boot();
    g_b.hal.cycles = NULL;
    fake_boot(&g_b, &g_app);
    fake_clear_tx(&g_b);
    h_send_empty(&g_b, STAC_MSG_GET_STATUS, ++g_seq);
    n = pass();
    f = fake_last(g_frames, n, STAC_MSG_STATUS);
    CHECK(f != NULL);
    stac_status_unpack(&s, f->payload, f->len);
    CHECK_EQ(s.cycle_hz, 0u);
    CHECK_EQ(s.acq_cycles_last, 0u);
}

const test_case_t g_store_tests[] = {
    {"store_fixture_fits", store_fixture_fits},
    {"store_empty_reports_capacity_and_limits", store_empty_reports_capacity_and_limits},
    {"store_upload_commit_and_info", store_upload_commit_and_info},
    {"store_any_chunk_length_lands_in_flash", store_any_chunk_length_lands_in_flash},
    {"store_model_survives_reboot_and_clear_removes_it",
     store_model_survives_reboot_and_clear_removes_it},
    {"store_begin_rejects_sizes", store_begin_rejects_sizes},
    {"store_begin_erases_only_the_sectors_the_image_needs",
     store_begin_erases_only_the_sectors_the_image_needs},
    {"store_begin_invalidates_at_once", store_begin_invalidates_at_once},
    {"store_refused_begin_changes_nothing", store_refused_begin_changes_nothing},
    {"store_model_info_reports_the_image_crc", store_model_info_reports_the_image_crc},
    {"store_commit_and_boot_refresh_the_watchdog_once_per_block",
     store_commit_and_boot_refresh_the_watchdog_once_per_block},
    {"store_decode_runs_after_the_next_trigger", store_decode_runs_after_the_next_trigger},
    {"store_status_reports_cycle_counts", store_status_reports_cycle_counts},
    {"store_chunks_out_of_order_duplicate_or_past_the_end",
     store_chunks_out_of_order_duplicate_or_past_the_end},
    {"store_commit_refusals_leave_no_model", store_commit_refusals_leave_no_model},
    {"store_power_cut_at_every_word_never_leaves_a_half_model",
     store_power_cut_at_every_word_never_leaves_a_half_model},
    {"store_reset_between_commands_never_leaves_a_model",
     store_reset_between_commands_never_leaves_a_model},
    {"store_flash_failure_at_every_operation_is_flash_error",
     store_flash_failure_at_every_operation_is_flash_error},
    {"store_damaged_flash_is_not_used_at_boot", store_damaged_flash_is_not_used_at_boot},
    {"store_configure_estimate_needs_a_matching_model",
     store_configure_estimate_needs_a_matching_model},
    {"store_estimate_follows_its_sample", store_estimate_follows_its_sample},
    {"store_estimate_only_suppresses_samples", store_estimate_only_suppresses_samples},
    {"store_estimates_restart_with_sample_seq_after_start",
     store_estimates_restart_with_sample_seq_after_start},
    {NULL, NULL},
};
