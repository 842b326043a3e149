#include "stac_frame.h"

#include <string.h>

#include "stac_cobs.h"
#include "stac_crc32c.h"

size_t stac_frame_encode_version(uint8_t major, uint8_t minor, uint8_t type, uint16_t seq,
                                 const uint8_t *payload, size_t len, uint8_t *out, size_t cap) {
    uint8_t raw[STAC_MAX_DECODED];
    if (len > STAC_MAX_PAYLOAD) {
        return 0u;
    }
    raw[0] = major;
    raw[1] = minor;
    raw[2] = type;
    raw[3] = (uint8_t)seq;
    raw[4] = (uint8_t)(seq >> 8);
    if (len > 0u) {
        memcpy(raw + STAC_HEADER_SIZE, payload, len);
    }
    size_t n = STAC_HEADER_SIZE + len;
    const uint32_t crc = stac_crc32c(raw, n);
    raw[n++] = (uint8_t)crc;
    raw[n++] = (uint8_t)(crc >> 8);
    raw[n++] = (uint8_t)(crc >> 16);
    raw[n++] = (uint8_t)(crc >> 24);
    if (cap < 1u) {
        return 0u;
    }
    const size_t enc = stac_cobs_encode(raw, n, out, cap - 1u);
    if (enc == 0u) {
        return 0u;
    }
    out[enc] = 0u;
    return enc + 1u;
}

size_t stac_frame_encode(uint8_t type, uint16_t seq, const uint8_t *payload, size_t len,
                         uint8_t *out, size_t cap) {
    return stac_frame_encode_version((uint8_t)STAC_PROTOCOL_MAJOR, (uint8_t)STAC_PROTOCOL_MINOR,
                                     type, seq, payload, len, out, cap);
}

stac_frame_status_t stac_frame_decode(const uint8_t *encoded, size_t len,
                                      uint8_t raw[STAC_MAX_DECODED], stac_frame_header_t *hdr,
                                      const uint8_t **payload, size_t *payload_len) {
    /* Same order of checks as the host decoder so that both name a bad frame alike. */
    if (len > STAC_MAX_ENCODED) {
        return STAC_FRAME_OVERSIZE;
    }
    /* COBS never decodes to more bytes than it was given, so tmp cannot overflow; a decode
     * longer than a legal frame is told apart from malformed COBS below. */
    uint8_t tmp[STAC_MAX_ENCODED];
    const int32_t n = stac_cobs_decode(encoded, len, tmp, sizeof tmp);
    if (n < 0) {
        return STAC_FRAME_BAD_COBS;
    }
    if ((size_t)n < STAC_MIN_DECODED) {
        return STAC_FRAME_TOO_SHORT;
    }
    if ((size_t)n > STAC_MAX_DECODED) {
        return STAC_FRAME_OVERSIZE;
    }
    if (stac_crc32c(tmp, (size_t)n) != STAC_CRC32C_RESIDUE) {
        return STAC_FRAME_BAD_CRC;
    }
    memcpy(raw, tmp, (size_t)n);
    hdr->major = raw[0];
    hdr->minor = raw[1];
    hdr->type = raw[2];
    hdr->seq = (uint16_t)(raw[3] | (raw[4] << 8));
    *payload = raw + STAC_HEADER_SIZE;
    *payload_len = (size_t)n - STAC_MIN_DECODED;
    return STAC_FRAME_OK;
}

void stac_rx_reset(stac_rx_t *rx) {
    rx->len = 0u;
    rx->overflow = false;
    rx->closed = false;
}

stac_rx_event_t stac_rx_push(stac_rx_t *rx, uint8_t byte) {
    if (rx->closed) {
        /* The frame returned by the previous push has been consumed by now. */
        rx->len = 0u;
        rx->closed = false;
    }
    if (byte == 0u) {
        const bool overflow = rx->overflow;
        const bool empty = rx->len == 0u;
        rx->overflow = false;
        if (overflow) {
            rx->len = 0u;
            return STAC_RX_OVERSIZE;
        }
        /* Back-to-back delimiters are idle filler, not frames. */
        rx->closed = !empty;
        return empty ? STAC_RX_NONE : STAC_RX_FRAME;
    }
    if (rx->overflow) {
        return STAC_RX_NONE;
    }
    if (rx->len >= STAC_MAX_ENCODED) {
        rx->overflow = true;
        return STAC_RX_NONE;
    }
    rx->buf[rx->len++] = byte;
    return STAC_RX_NONE;
}
