/* Golden-vector probe for tests/firmware/test_vectors_c.py. Reads one wire frame per line (hex,
 * delimiter included) and prints what the firmware's decoder makes of it:
 *   <kind> <major> <minor> <type> <seq> <payload hex> <re-encoded frame hex>
 * kind is ok or the golden-vector error name. The payload is the frame's payload unpacked into
 * the generated struct and packed again (zero-filled / truncated to this version's layout), and
 * the re-encoded frame is that payload framed again by the firmware encoder; "-" when empty. */
#include <stdio.h>
#include <string.h>

#include "stac_frame.h"

static int hexval(int c) {
    if (c >= '0' && c <= '9') return c - '0';
    if (c >= 'a' && c <= 'f') return c - 'a' + 10;
    if (c >= 'A' && c <= 'F') return c - 'A' + 10;
    return -1;
}

static void print_hex(const uint8_t *p, size_t n) {
    if (n == 0u) {
        fputs("-", stdout);
    }
    for (size_t i = 0; i < n; i++) {
        printf("%02x", p[i]);
    }
}

/* Unpack into the generated struct and pack again: the decoded fields, canonically. */
static size_t canonical(uint8_t type, const uint8_t *in, size_t len, uint8_t *out) {
#define ROUNDTRIP(T, name)                 \
    {                                      \
        T m;                               \
        name##_unpack(&m, in, len);        \
        return name##_pack(&m, out);       \
    }
    switch (type) {
    case STAC_MSG_CONFIGURE: ROUNDTRIP(stac_configure_t, stac_configure)
    case STAC_MSG_TIME_SYNC_REQUEST: ROUNDTRIP(stac_time_sync_request_t, stac_time_sync_request)
    case STAC_MSG_INFO: ROUNDTRIP(stac_info_t, stac_info)
    case STAC_MSG_ACK: ROUNDTRIP(stac_ack_t, stac_ack)
    case STAC_MSG_NACK: ROUNDTRIP(stac_nack_t, stac_nack)
    case STAC_MSG_SAMPLE: ROUNDTRIP(stac_sample_t, stac_sample)
    case STAC_MSG_STATUS: ROUNDTRIP(stac_status_t, stac_status)
    case STAC_MSG_TIME_SYNC_REPLY: ROUNDTRIP(stac_time_sync_reply_t, stac_time_sync_reply)
    case STAC_MSG_LOG: ROUNDTRIP(stac_log_t, stac_log)
    case STAC_MSG_CONFIG: ROUNDTRIP(stac_config_t, stac_config)
    case STAC_MSG_MODEL_BEGIN: ROUNDTRIP(stac_model_begin_t, stac_model_begin)
    case STAC_MSG_MODEL_CHUNK: ROUNDTRIP(stac_model_chunk_t, stac_model_chunk)
    case STAC_MSG_MODEL_COMMIT: ROUNDTRIP(stac_model_commit_t, stac_model_commit)
    case STAC_MSG_MODEL_INFO: ROUNDTRIP(stac_model_info_t, stac_model_info)
    case STAC_MSG_ESTIMATE: ROUNDTRIP(stac_estimate_t, stac_estimate)
    case STAC_MSG_DEBUG_FAULT: ROUNDTRIP(stac_debug_fault_t, stac_debug_fault)
    default: return 0u; /* messages without fields */
    }
#undef ROUNDTRIP
}

int main(void) {
    static char line[8192];
    static const char *const k_kind[] = {"ok", "bad_cobs", "too_short", "oversize", "bad_crc"};
    while (fgets(line, sizeof line, stdin) != NULL) {
        uint8_t wire[4096];
        size_t n = 0;
        for (size_t i = 0; hexval(line[i]) >= 0 && hexval(line[i + 1]) >= 0 && n < sizeof wire;
             i += 2) {
            wire[n++] = (uint8_t)(hexval(line[i]) * 16 + hexval(line[i + 1]));
        }
        if (n == 0u || wire[n - 1] != 0u) {
            printf("no_delimiter 0 0 0 0 - -\n");
            continue;
        }
        uint8_t raw[STAC_MAX_DECODED];
        stac_frame_header_t h = {0, 0, 0, 0};
        const uint8_t *payload = NULL;
        size_t plen = 0;
        const stac_frame_status_t st = stac_frame_decode(wire, n - 1u, raw, &h, &payload, &plen);
        const char *kind = k_kind[st];
        if (st == STAC_FRAME_OK && h.major != STAC_PROTOCOL_MAJOR) {
            kind = "version_mismatch";
        } else if (st == STAC_FRAME_OK && stac_payload_size(h.type) < 0) {
            kind = "unknown_type";
        } else if (st == STAC_FRAME_OK && plen < (size_t)stac_payload_min_size(h.type, h.minor)) {
            kind = "short_payload";
        }
        printf("%s %u %u %u %u ", kind, h.major, h.minor, h.type, h.seq);
        if (strcmp(kind, "ok") != 0) {
            printf("- -\n");
            continue;
        }
        uint8_t canon[STAC_MAX_PAYLOAD];
        const size_t cn = canonical(h.type, payload, plen, canon);
        print_hex(canon, cn);
        fputs(" ", stdout);
        /* Re-encoded in the frame's own minor version: that version's layout, no newer field. */
        const size_t layout = (size_t)stac_payload_min_size(h.type, h.minor);
        uint8_t out[STAC_MAX_FRAME];
        const size_t on = stac_frame_encode_version(h.major, h.minor, h.type, h.seq, canon,
                                                    cn < layout ? cn : layout, out, sizeof out);
        print_hex(out, on);
        fputs("\n", stdout);
    }
    return 0;
}
