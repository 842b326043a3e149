/* VEML3328 driver against the fake register-level sensor. */
#include <string.h>

#include "check.h"
#include "fake_board.h"
#include "veml3328.h"

static fake_board_t g_b;

TEST(driver_probe_ok) {
    fake_init(&g_b);
    CHECK_EQ(veml3328_probe(&g_b.hal, 0), STAC_I2C_OK);
}

TEST(driver_probe_absent_nack) {
    fake_init(&g_b);
    g_b.s[1].mode = FAKE_ABSENT;
    CHECK_EQ(veml3328_probe(&g_b.hal, 1), STAC_I2C_NACK);
}

TEST(driver_probe_stall_is_bounded) {
    fake_init(&g_b);
    g_b.s[2].mode = FAKE_STALL;
    const uint32_t t0 = g_b.now;
    CHECK_EQ(veml3328_probe(&g_b.hal, 2), STAC_I2C_TIMEOUT);
    /* The driver asks for a bounded wait and the port honours it. */
    CHECK(g_b.now - t0 <= VEML3328_TIMEOUT_US);
}

TEST(driver_probe_wrong_id) {
    fake_init(&g_b);
    g_b.s[0].mode = FAKE_WRONG_ID;
    CHECK_EQ(veml3328_probe(&g_b.hal, 0), VEML3328_WRONG_ID);
}

TEST(driver_conf_word_bits) {
    veml3328_settings_t s = {.it_code = 0, .gain = 0, .dg = 0, .sens_low = 0};
    /* Running (SD bits 15 and 0 clear), active force mode, no trigger. */
    CHECK_EQ(veml3328_conf_word(&s, false), 0x0008);
    CHECK_EQ(veml3328_conf_word(&s, true), 0x000C);
    s.it_code = (uint8_t)veml3328_it_code(400);
    CHECK_EQ(veml3328_conf_word(&s, false), 0x0038);
    s = (veml3328_settings_t){.it_code = 1, .gain = 2, .dg = 1, .sens_low = 1};
    CHECK_EQ(veml3328_conf_word(&s, false), 0x1000 | 0x0800 | 0x0040 | 0x0010 | 0x0008);
    s = (veml3328_settings_t){.it_code = 2, .gain = 3, .dg = 2, .sens_low = 0};
    CHECK_EQ(veml3328_conf_word(&s, true), 0x2000 | 0x0C00 | 0x0020 | 0x0008 | 0x0004);
    CHECK_EQ(veml3328_it_code(50), 0);
    CHECK_EQ(veml3328_it_code(100), 1);
    CHECK_EQ(veml3328_it_code(200), 2);
    CHECK_EQ(veml3328_it_code(75), -1);
}

TEST(driver_register_byte_order) {
    fake_init(&g_b);
    CHECK_EQ(veml3328_write_reg(&g_b.hal, 0, VEML3328_REG_CONF, 0x1234), STAC_I2C_OK);
    CHECK_EQ(g_b.s[0].conf, 0x1234);
    uint16_t v = 0;
    CHECK_EQ(veml3328_read_reg(&g_b.hal, 0, VEML3328_REG_CONF, &v), STAC_I2C_OK);
    CHECK_EQ(v, 0x1234);
    CHECK_EQ(veml3328_read_reg(&g_b.hal, 0, VEML3328_REG_ID, &v), STAC_I2C_OK);
    CHECK_EQ(v & 0xFF, 0x28);
}

TEST(driver_trigger_poll_read) {
    fake_init(&g_b);
    const veml3328_settings_t s = {.it_code = 0, .gain = 0, .dg = 0, .sens_low = 0};
    CHECK_EQ(veml3328_configure(&g_b.hal, 1, &s), STAC_I2C_OK);
    CHECK_EQ(g_b.s[1].triggers, 0);
    CHECK_EQ(veml3328_trigger(&g_b.hal, 1, &s), STAC_I2C_OK);
    CHECK_EQ(g_b.s[1].triggers, 1);
    bool done = true;
    CHECK_EQ(veml3328_poll_done(&g_b.hal, 1, &done), STAC_I2C_OK);
    CHECK(!done);
    g_b.now += 50000;
    CHECK_EQ(veml3328_poll_done(&g_b.hal, 1, &done), STAC_I2C_OK);
    CHECK(done);
    uint16_t c[VEML3328_CHANNELS];
    bool sat = true;
    CHECK_EQ(veml3328_read_channels(&g_b.hal, 1, c, &sat), STAC_I2C_OK);
    CHECK(!sat);
    /* Order R, G, B, C, IR: the fake's base counts are 1000*(k+1) + 100*ch. */
    for (int ch = 0; ch < 5; ch++) {
        CHECK_EQ(c[ch], 2000 + 100 * ch);
    }
}

TEST(driver_detects_saturation) {
    fake_init(&g_b);
    g_b.s[0].saturate = true;
    const veml3328_settings_t s = {.it_code = 0, .gain = 0, .dg = 0, .sens_low = 0};
    CHECK_EQ(veml3328_trigger(&g_b.hal, 0, &s), STAC_I2C_OK);
    g_b.now += 60000;
    bool done = false;
    CHECK_EQ(veml3328_poll_done(&g_b.hal, 0, &done), STAC_I2C_OK);
    CHECK(done);
    uint16_t c[VEML3328_CHANNELS];
    bool sat = false;
    CHECK_EQ(veml3328_read_channels(&g_b.hal, 0, c, &sat), STAC_I2C_OK);
    CHECK(sat);
    CHECK_EQ(c[0], 0xFFFF);
}

TEST(driver_read_fails_midway) {
    fake_init(&g_b);
    uint16_t c[VEML3328_CHANNELS];
    bool sat = false;
    g_b.s[0].fail_next = 1;
    g_b.s[0].fail_mode = FAKE_STALL;
    CHECK_EQ(veml3328_read_channels(&g_b.hal, 0, c, &sat), STAC_I2C_TIMEOUT);
    g_b.s[0].fail_next = 1;
    g_b.s[0].fail_mode = FAKE_BUS_ERROR;
    CHECK_EQ(veml3328_read_channels(&g_b.hal, 0, c, &sat), STAC_I2C_BUS_ERROR);
    CHECK_EQ(veml3328_read_channels(&g_b.hal, 0, c, &sat), STAC_I2C_OK);
}

TEST(driver_shutdown_sets_both_bits) {
    fake_init(&g_b);
    g_b.s[0].conf = 0;
    CHECK_EQ(veml3328_shutdown(&g_b.hal, 0), STAC_I2C_OK);
    CHECK_EQ(g_b.s[0].conf & 0x8001, 0x8001);
}

const test_case_t g_driver_tests[] = {
    {"driver_probe_ok", driver_probe_ok},
    {"driver_probe_absent_nack", driver_probe_absent_nack},
    {"driver_probe_stall_is_bounded", driver_probe_stall_is_bounded},
    {"driver_probe_wrong_id", driver_probe_wrong_id},
    {"driver_conf_word_bits", driver_conf_word_bits},
    {"driver_register_byte_order", driver_register_byte_order},
    {"driver_trigger_poll_read", driver_trigger_poll_read},
    {"driver_detects_saturation", driver_detects_saturation},
    {"driver_read_fails_midway", driver_read_fails_midway},
    {"driver_shutdown_sets_both_bits", driver_shutdown_sets_both_bits},
    {NULL, NULL},
};
