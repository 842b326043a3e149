/* CRC-32C, COBS, frame encode/decode and the receive accumulator. */
#include <string.h>

#include "check.h"
#include "stac_cobs.h"
#include "stac_crc32c.h"
#include "stac_frame.h"

static uint32_t g_rng = 12345u;
static uint32_t rnd(void) {
    g_rng = g_rng * 1664525u + 1013904223u;
    return g_rng >> 8;
}

TEST(crc32c_check_value) {
    CHECK_EQ(stac_crc32c((const uint8_t *)"123456789", 9), 0xE3069283u);
    uint8_t buf[13] = "123456789";
    const uint32_t crc = stac_crc32c(buf, 9);
    buf[9] = (uint8_t)crc;
    buf[10] = (uint8_t)(crc >> 8);
    buf[11] = (uint8_t)(crc >> 16);
    buf[12] = (uint8_t)(crc >> 24);
    CHECK_EQ(stac_crc32c(buf, 13), STAC_CRC32C_RESIDUE);
    /* Incremental use gives the same result. */
    CHECK_EQ(stac_crc32c_update(stac_crc32c(buf, 4), buf + 4, 5), 0xE3069283u);
}

TEST(cobs_known_encodings) {
    uint8_t out[300];
    const uint8_t z[1] = {0};
    CHECK_EQ(stac_cobs_encode(z, 1, out, sizeof out), 2);
    CHECK(out[0] == 1 && out[1] == 1);
    const uint8_t a[4] = {0x11, 0x22, 0x00, 0x33};
    CHECK_EQ(stac_cobs_encode(a, 4, out, sizeof out), 5);
    const uint8_t ea[5] = {0x03, 0x11, 0x22, 0x02, 0x33};
    CHECK(memcmp(out, ea, 5) == 0);
    CHECK_EQ(stac_cobs_encode(a, 0, out, sizeof out), 1);
    CHECK_EQ(out[0], 1);
    uint8_t run[255];
    for (int i = 0; i < 255; i++) {
        run[i] = (uint8_t)(i % 255 + 1);
    }
    /* 254 non-zero bytes: one full block and nothing after it. */
    CHECK_EQ(stac_cobs_encode(run, 254, out, sizeof out), 255);
    CHECK_EQ(out[0], 0xFF);
    /* 255 non-zero bytes: a full block, then a block of one. */
    CHECK_EQ(stac_cobs_encode(run, 255, out, sizeof out), 257);
    CHECK_EQ(out[255], 2);
    CHECK_EQ(stac_cobs_encode(run, 255, out, 256), 0); /* too small: refused */
}

TEST(cobs_roundtrip_random) {
    uint8_t in[600], enc[620], dec[600];
    for (int iter = 0; iter < 2000; iter++) {
        const size_t n = rnd() % 600u;
        for (size_t i = 0; i < n; i++) {
            in[i] = (rnd() % 4u == 0u) ? 0u : (uint8_t)rnd();
        }
        const size_t e = stac_cobs_encode(in, n, enc, sizeof enc);
        CHECK(e > 0 && e <= STAC_COBS_MAX_ENCODED(n));
        CHECK(memchr(enc, 0, e) == NULL);
        CHECK_EQ(stac_cobs_decode(enc, e, dec, sizeof dec), (long long)n);
        CHECK(memcmp(in, dec, n) == 0);
    }
}

TEST(cobs_rejects_malformed) {
    uint8_t out[16];
    const uint8_t past_end[3] = {0x05, 0x11, 0x22};
    CHECK_EQ(stac_cobs_decode(past_end, 3, out, sizeof out), -1);
    const uint8_t inner_zero[3] = {0x03, 0x00, 0x22};
    CHECK_EQ(stac_cobs_decode(inner_zero, 3, out, sizeof out), -1);
    const uint8_t zero_code[2] = {0x00, 0x01};
    CHECK_EQ(stac_cobs_decode(zero_code, 2, out, sizeof out), -1);
    const uint8_t big[5] = {0x05, 1, 2, 3, 4};
    CHECK_EQ(stac_cobs_decode(big, 5, out, 3), -1); /* output would overflow */
}

TEST(frame_roundtrip) {
    uint8_t wire[STAC_MAX_FRAME];
    const uint8_t payload[5] = {0x02, 0x07, 0x00, 0x03, 0x00};
    const size_t n = stac_frame_encode(STAC_MSG_ACK, 41, payload, 5, wire, sizeof wire);
    CHECK(n > 0 && wire[n - 1] == 0 && memchr(wire, 0, n - 1) == NULL);
    uint8_t raw[STAC_MAX_DECODED];
    stac_frame_header_t h;
    const uint8_t *p = NULL;
    size_t plen = 0;
    CHECK_EQ(stac_frame_decode(wire, n - 1, raw, &h, &p, &plen), STAC_FRAME_OK);
    CHECK_EQ(h.major, 1);
    CHECK_EQ(h.minor, STAC_PROTOCOL_MINOR);
    CHECK_EQ(h.type, STAC_MSG_ACK);
    CHECK_EQ(h.seq, 41);
    CHECK_EQ(plen, 5);
    CHECK(memcmp(p, payload, 5) == 0);
    /* Largest payload fits STAC_MAX_FRAME; one more byte is refused. */
    uint8_t big[STAC_MAX_PAYLOAD + 1];
    memset(big, 0xAB, sizeof big);
    CHECK(stac_frame_encode(0x10, 1, big, STAC_MAX_PAYLOAD, wire, sizeof wire) <= STAC_MAX_FRAME);
    CHECK(stac_frame_encode(0x10, 1, big, STAC_MAX_PAYLOAD, wire, sizeof wire) > 0);
    CHECK_EQ(stac_frame_encode(0x10, 1, big, STAC_MAX_PAYLOAD + 1, wire, sizeof wire), 0);
}

TEST(frame_errors_are_named) {
    uint8_t wire[STAC_MAX_FRAME];
    uint8_t raw[STAC_MAX_DECODED];
    stac_frame_header_t h;
    const uint8_t *p = NULL;
    size_t plen = 0;
    /* A well-stuffed frame whose CRC is wrong. */
    const uint8_t wrong_crc[9] = {1, 0, STAC_MSG_GET_INFO, 3, 0, 0x11, 0x22, 0x33, 0x44};
    const size_t n = stac_cobs_encode(wrong_crc, sizeof wrong_crc, wire, sizeof wire);
    CHECK_EQ(stac_frame_decode(wire, n, raw, &h, &p, &plen), STAC_FRAME_BAD_CRC);
    const uint8_t short_frame[4] = {0x04, 0x01, 0x02, 0x03};
    CHECK_EQ(stac_frame_decode(short_frame, 4, raw, &h, &p, &plen), STAC_FRAME_TOO_SHORT);
    const uint8_t bad[3] = {0x07, 0x01, 0x02};
    CHECK_EQ(stac_frame_decode(bad, 3, raw, &h, &p, &plen), STAC_FRAME_BAD_COBS);
    uint8_t huge[STAC_MAX_FRAME];
    memset(huge, 0x11, sizeof huge);
    CHECK_EQ(stac_frame_decode(huge, STAC_MAX_ENCODED + 1, raw, &h, &p, &plen),
             STAC_FRAME_OVERSIZE);
    /* A legal COBS run that decodes to more than a frame may hold is oversize too. */
    uint8_t dec_big[STAC_MAX_DECODED + 1];
    memset(dec_big, 0x22, sizeof dec_big);
    const size_t e = stac_cobs_encode(dec_big, sizeof dec_big, huge, sizeof huge);
    CHECK(e > 0 && e <= STAC_MAX_ENCODED);
    CHECK_EQ(stac_frame_decode(huge, e, raw, &h, &p, &plen), STAC_FRAME_OVERSIZE);
}

TEST(rx_accumulator_resyncs) {
    stac_rx_t rx;
    stac_rx_reset(&rx);
    /* Idle delimiters are not frames. */
    CHECK_EQ(stac_rx_push(&rx, 0), STAC_RX_NONE);
    CHECK_EQ(stac_rx_push(&rx, 0), STAC_RX_NONE);
    for (int i = 0; i < 5; i++) {
        CHECK_EQ(stac_rx_push(&rx, (uint8_t)(0x30 + i)), STAC_RX_NONE);
    }
    CHECK_EQ(stac_rx_push(&rx, 0), STAC_RX_FRAME);
    CHECK_EQ(rx.len, 5);
    CHECK_EQ(rx.buf[0], 0x30);
    /* An overlong run is reported once, at its delimiter, then framing resumes. */
    for (int i = 0; i < 1000; i++) {
        CHECK_EQ(stac_rx_push(&rx, 0x5A), STAC_RX_NONE);
    }
    CHECK_EQ(stac_rx_push(&rx, 0), STAC_RX_OVERSIZE);
    CHECK_EQ(stac_rx_push(&rx, 0x01), STAC_RX_NONE);
    CHECK_EQ(stac_rx_push(&rx, 0), STAC_RX_FRAME);
    CHECK_EQ(rx.len, 1);
    /* Exactly STAC_MAX_ENCODED bytes is still a frame. */
    for (unsigned i = 0; i < STAC_MAX_ENCODED; i++) {
        CHECK_EQ(stac_rx_push(&rx, 0x01), STAC_RX_NONE);
    }
    CHECK_EQ(stac_rx_push(&rx, 0), STAC_RX_FRAME);
    CHECK_EQ(rx.len, STAC_MAX_ENCODED);
}

const test_case_t g_codec_tests[] = {
    {"crc32c_check_value", crc32c_check_value},
    {"cobs_known_encodings", cobs_known_encodings},
    {"cobs_roundtrip_random", cobs_roundtrip_random},
    {"cobs_rejects_malformed", cobs_rejects_malformed},
    {"frame_roundtrip", frame_roundtrip},
    {"frame_errors_are_named", frame_errors_are_named},
    {"rx_accumulator_resyncs", rx_accumulator_resyncs},
    {NULL, NULL},
};
