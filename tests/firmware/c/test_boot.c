/* Protocol 1.4 in the core: the boot's report (reset cause, fault record, brown-out level) in
 * STATUS and one LOG, safe mode without the model store, MODEL_BEGIN refused below brown-out
 * level 3, the measured erase time, ENTER_BOOTLOADER and DEBUG_FAULT (test images only). */
#include <string.h>

#include "check.h"
#include "helpers.h"
#include "stac_crc32c.h"

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

/* Send a command, run a pass: the frames it produced. */
static int command(uint8_t type, const uint8_t *payload, size_t len) {
    fake_clear_tx(&g_b);
    fake_send(&g_b, type, ++g_seq, payload, len);
    return pass();
}

static stac_status_t status(void) {
    stac_status_t m;
    memset(&m, 0xEE, sizeof m);
    const int n = command(STAC_MSG_GET_STATUS, NULL, 0u);
    const fake_frame_t *f = fake_last(g_frames, n, STAC_MSG_STATUS);
    if (f != NULL) {
        stac_status_unpack(&m, f->payload, f->len);
    }
    return m;
}

/* The NACK error among n frames, STAC_OK for an ACK, 0xFFFF for neither. */
static uint16_t answer(int n) {
    for (int i = 0; i < n; i++) {
        if (g_frames[i].h.type == STAC_MSG_ACK) {
            return STAC_OK;
        }
        if (g_frames[i].h.type == STAC_MSG_NACK) {
            stac_nack_t m;
            stac_nack_unpack(&m, g_frames[i].payload, g_frames[i].len);
            return m.error;
        }
    }
    return 0xFFFFu;
}

static uint16_t begin(uint32_t size) {
    const uint32_t crc = size == test_model_image_size ? stac_crc32c(test_model_image, size) : 0u;
    const stac_model_begin_t m = {.model_id = 7u, .size = size, .crc = crc};
    uint8_t p[STAC_MODEL_BEGIN_SIZE];
    return answer(command(STAC_MSG_MODEL_BEGIN, p, stac_model_begin_pack(&m, p)));
}

static const stac_boot_t k_fault_boot = {
    .reset_cause = STAC_RESET_PIN | STAC_RESET_SOFTWARE | STAC_RESET_FAULT,
    .abnormal_resets = 1u,
    .bor_level = 3u,
    .fault_pc = 0x08001A2Cu,
    .fault_lr = 0x08000F13u,
    .fault_xpsr = 0x01000003u,
    .fault_cfsr = 0x00010000u,
    .fault_hfsr = 0x40000000u,
    .fault_mmfar = 0xE000EDF4u,
    .fault_bfar = 0xE000EDF8u,
};

static void boot_with(const stac_boot_t *boot) {
    fake_init(&g_b);
    if (boot != NULL) {
        g_b.boot = *boot;
    }
    fake_boot(&g_b, &g_app);
    g_seq = 0u;
}

TEST(boot_status_reports_the_fault_record) {
    boot_with(&k_fault_boot);
    const stac_status_t m = status();
    CHECK_EQ(m.reset_cause, STAC_RESET_PIN | STAC_RESET_SOFTWARE | STAC_RESET_FAULT);
    CHECK_EQ(m.fault_pc, 0x08001A2Cu);
    CHECK_EQ(m.fault_lr, 0x08000F13u);
    CHECK_EQ(m.fault_xpsr, 0x01000003u);
    CHECK_EQ(m.fault_cfsr, 0x00010000u);
    CHECK_EQ(m.fault_hfsr, 0x40000000u);
    CHECK_EQ(m.fault_mmfar, 0xE000EDF4u);
    CHECK_EQ(m.fault_bfar, 0xE000EDF8u);
    CHECK_EQ(m.abnormal_resets, 1);
    CHECK_EQ(m.safe_mode, 0);
    CHECK_EQ(m.bor_level, 3);
    /* They describe the boot, not statistics: RESET_STATS keeps them. */
    CHECK_EQ(answer(command(STAC_MSG_RESET_STATS, NULL, 0u)), STAC_OK);
    CHECK_EQ(status().fault_pc, 0x08001A2Cu);
}

TEST(boot_log_goes_out_once_with_the_first_answer) {
    boot_with(&k_fault_boot);
    CHECK_EQ(h_frames(&g_b), 0); /* nobody listens at boot: nothing is sent then */
    int n = command(STAC_MSG_GET_INFO, NULL, 0u);
    CHECK_EQ(fake_count(g_frames, n, STAC_MSG_LOG), 1);
    CHECK_EQ(fake_count(g_frames, n, STAC_MSG_INFO), 1);
    const fake_frame_t *f = fake_last(g_frames, n, STAC_MSG_LOG);
    stac_log_t log;
    stac_log_unpack(&log, f->payload, f->len);
    CHECK_EQ(log.level, STAC_LOG_ERROR);
    CHECK(strstr(log.text, "fault") != NULL);
    CHECK(strstr(log.text, "pc=08001A2C") != NULL);
    CHECK(strstr(log.text, "cfsr=00010000") != NULL);
    n = command(STAC_MSG_GET_INFO, NULL, 0u);
    CHECK_EQ(fake_count(g_frames, n, STAC_MSG_LOG), 0);
}

TEST(boot_log_silent_after_a_clean_power_on) {
    boot_with(NULL);
    const int n = command(STAC_MSG_GET_INFO, NULL, 0u);
    CHECK_EQ(fake_count(g_frames, n, STAC_MSG_LOG), 0);
    CHECK_EQ(n, 1);
}

TEST(boot_log_carries_the_ports_note) {
    stac_boot_t b = {.reset_cause = STAC_RESET_POWER, .bor_level = 3u, .note = "HSI 16MHz"};
    boot_with(&b);
    const int n = command(STAC_MSG_GET_INFO, NULL, 0u);
    CHECK_EQ(fake_count(g_frames, n, STAC_MSG_LOG), 1);
    stac_log_t log;
    const fake_frame_t *f = fake_last(g_frames, n, STAC_MSG_LOG);
    stac_log_unpack(&log, f->payload, f->len);
    CHECK_EQ(log.level, STAC_LOG_WARN);
    CHECK(strcmp(log.text, "HSI 16MHz") == 0);
}

TEST(boot_safe_mode_skips_the_model_store) {
    /* A stored model first, on a board that boots normally. */
    boot_with(NULL);
    CHECK_EQ(begin(test_model_image_size), STAC_OK);
    for (uint32_t off = 0u; off < test_model_image_size; off += 200u) {
        stac_model_chunk_t c;
        memset(&c, 0, sizeof c);
        c.offset = off;
        c.length = (uint8_t)(test_model_image_size - off < 200u ? test_model_image_size - off
                                                                 : 200u);
        memcpy(c.data, test_model_image + off, c.length);
        uint8_t p[STAC_MODEL_CHUNK_SIZE];
        CHECK_EQ(answer(command(STAC_MSG_MODEL_CHUNK, p, stac_model_chunk_pack(&c, p))), STAC_OK);
    }
    const stac_model_commit_t cm = {.model_id = 7u};
    uint8_t p[STAC_MODEL_COMMIT_SIZE];
    CHECK_EQ(answer(command(STAC_MSG_MODEL_COMMIT, p, stac_model_commit_pack(&cm, p))), STAC_OK);
    CHECK(stac_store_model(&g_app.store) != NULL);
    /* The third watchdog reset in a row: the port boots in safe mode. */
    fake_clear_tx(&g_b);
    g_b.boot.reset_cause = STAC_RESET_PIN | STAC_RESET_IWDG;
    g_b.boot.abnormal_resets = 3u;
    g_b.boot.safe_mode = 1u;
    fake_boot(&g_b, &g_app);
    CHECK(stac_store_model(&g_app.store) == NULL);
    const int n = command(STAC_MSG_GET_MODEL, NULL, 0u);
    const fake_frame_t *f = fake_last(g_frames, n, STAC_MSG_LOG);
    CHECK(f != NULL);
    stac_log_t log;
    stac_log_unpack(&log, f->payload, f->len);
    CHECK(strstr(log.text, "iwdg") != NULL);
    CHECK(strstr(log.text, "SAFE MODE") != NULL);
    const stac_status_t m = status();
    CHECK_EQ(m.safe_mode, 1);
    CHECK_EQ(m.abnormal_resets, 3);
    /* The flash still holds the model: a normal boot opens it again. */
    g_b.boot.safe_mode = 0u;
    g_b.boot.abnormal_resets = 0u;
    fake_boot(&g_b, &g_app);
    CHECK(stac_store_model(&g_app.store) != NULL);
}

TEST(boot_model_begin_refused_below_bor_level_3) {
    stac_boot_t low = {.reset_cause = STAC_RESET_POWER, .bor_level = 2u};
    boot_with(&low);
    const uint32_t erases = g_b.flash_erases;
    CHECK_EQ(begin(1024u), STAC_BOR_TOO_LOW);
    CHECK_EQ(g_b.flash_erases, erases); /* refused before anything changed */
    CHECK_EQ(status().bor_level, 2);
    low.bor_level = 0u;
    boot_with(&low);
    CHECK_EQ(begin(1024u), STAC_BOR_TOO_LOW);
    low.bor_level = 3u;
    boot_with(&low);
    CHECK_EQ(begin(1024u), STAC_OK);
}

TEST(boot_erase_time_is_measured) {
    boot_with(NULL);
    CHECK_EQ(status().erase_us_last, 0);
    g_b.erase_us_per_sector = 1500000u; /* 1.5 s per sector */
    CHECK_EQ(begin(1024u), STAC_OK);   /* sector 0 and the record's sector */
    stac_status_t m = status();
    CHECK(m.erase_us_last >= 2u * 1500000u && m.erase_us_last < 2u * 1500000u + 10000u);
    CHECK_EQ(m.erase_us_max, m.erase_us_last);
    CHECK_EQ(answer(command(STAC_MSG_MODEL_CLEAR, NULL, 0u)), STAC_OK); /* all 4 sectors */
    m = status();
    CHECK(m.erase_us_last >= 4u * 1500000u && m.erase_us_last < 4u * 1500000u + 10000u);
    CHECK_EQ(m.erase_us_max, m.erase_us_last);
    g_b.erase_us_per_sector = 1000u;
    CHECK_EQ(answer(command(STAC_MSG_MODEL_CLEAR, NULL, 0u)), STAC_OK);
    m = status();
    CHECK(m.erase_us_last < 10000u + 4000u);
    CHECK(m.erase_us_max >= 4u * 1500000u);
    /* Without a cycle counter the clock (which runs through the stall) times it. */
    g_b.hal.cycles = NULL;
    fake_boot(&g_b, &g_app);
    g_b.erase_us_per_sector = 250000u;
    CHECK_EQ(answer(command(STAC_MSG_MODEL_CLEAR, NULL, 0u)), STAC_OK);
    CHECK_EQ(status().erase_us_last, 4u * 250000u);
}

TEST(boot_release_image_refuses_debug_fault_and_bootloader) {
    boot_with(NULL);
    const stac_debug_fault_t df = {.kind = STAC_FAULT_HARD};
    uint8_t p[STAC_DEBUG_FAULT_SIZE];
    CHECK_EQ(answer(command(STAC_MSG_DEBUG_FAULT, p, stac_debug_fault_pack(&df, p))),
             STAC_NOT_A_TEST_IMAGE);
    CHECK_EQ(answer(command(STAC_MSG_ENTER_BOOTLOADER, NULL, 0u)), STAC_UNKNOWN_TYPE);
    const int n = command(STAC_MSG_GET_INFO, NULL, 0u);
    stac_info_t info;
    stac_info_unpack(&info, fake_last(g_frames, n, STAC_MSG_INFO)->payload, STAC_INFO_SIZE);
    CHECK_EQ(info.capabilities & (STAC_CAP_BOOTLOADER | STAC_CAP_DEBUG_FAULT), 0);
}

TEST(boot_test_image_acks_then_faults) {
    fake_init(&g_b);
    fake_test_image(&g_b);
    fake_boot(&g_b, &g_app);
    int n = command(STAC_MSG_GET_INFO, NULL, 0u);
    stac_info_t info;
    stac_info_unpack(&info, fake_last(g_frames, n, STAC_MSG_INFO)->payload, STAC_INFO_SIZE);
    CHECK_EQ(info.capabilities & (STAC_CAP_BOOTLOADER | STAC_CAP_DEBUG_FAULT),
             STAC_CAP_BOOTLOADER | STAC_CAP_DEBUG_FAULT);
    uint8_t p[STAC_DEBUG_FAULT_SIZE] = {7u};
    CHECK_EQ(answer(command(STAC_MSG_DEBUG_FAULT, p, 1u)), STAC_BAD_FAULT_KIND);
    CHECK_EQ(g_b.fault_calls, 0);
    p[0] = STAC_FAULT_HANG;
    n = command(STAC_MSG_DEBUG_FAULT, p, 1u);
    CHECK_EQ(answer(n), STAC_OK);
    CHECK_EQ(g_b.fault_calls, 1);
    CHECK_EQ(g_b.fault_kind, STAC_FAULT_HANG);
    CHECK_EQ(g_b.tx_len_at_hook, g_b.tx_len); /* the ACK was queued before the fault */
    /* ENTER_BOOTLOADER stops streaming, ACKs, then hands over. */
    h_send_empty(&g_b, STAC_MSG_START, ++g_seq);
    pass();
    CHECK(g_app.streaming);
    n = command(STAC_MSG_ENTER_BOOTLOADER, NULL, 0u);
    CHECK_EQ(answer(n), STAC_OK);
    CHECK_EQ(g_b.bootloader_calls, 1);
    CHECK(!g_app.streaming);
    CHECK(g_b.tx_len_at_hook > 0u);
}

const test_case_t g_boot_tests[] = {
    {"boot_status_reports_the_fault_record", boot_status_reports_the_fault_record},
    {"boot_log_goes_out_once_with_the_first_answer", boot_log_goes_out_once_with_the_first_answer},
    {"boot_log_silent_after_a_clean_power_on", boot_log_silent_after_a_clean_power_on},
    {"boot_log_carries_the_ports_note", boot_log_carries_the_ports_note},
    {"boot_safe_mode_skips_the_model_store", boot_safe_mode_skips_the_model_store},
    {"boot_model_begin_refused_below_bor_level_3", boot_model_begin_refused_below_bor_level_3},
    {"boot_erase_time_is_measured", boot_erase_time_is_measured},
    {"boot_release_image_refuses_debug_fault_and_bootloader",
     boot_release_image_refuses_debug_fault_and_bootloader},
    {"boot_test_image_acks_then_faults", boot_test_image_acks_then_faults},
    {NULL, NULL},
};
