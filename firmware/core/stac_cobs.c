#include "stac_cobs.h"

size_t stac_cobs_encode(const uint8_t *in, size_t len, uint8_t *out, size_t cap) {
    if (cap < STAC_COBS_MAX_ENCODED(len)) {
        return 0u;
    }
    size_t code_at = 0u; /* where the current block's code byte goes */
    size_t o = 1u;
    uint8_t code = 1u;
    for (size_t i = 0; i < len; i++) {
        if (in[i] == 0u) {
            out[code_at] = code;
            code_at = o++;
            code = 1u;
            continue;
        }
        out[o++] = in[i];
        if (++code == 0xFFu && i + 1u < len) {
            /* A full block of 254 data bytes carries no implied zero; open the next block
             * only if data follows (as the reference encoder does). */
            out[code_at] = code;
            code_at = o++;
            code = 1u;
        }
    }
    out[code_at] = code;
    return o;
}

int32_t stac_cobs_decode(const uint8_t *in, size_t len, uint8_t *out, size_t cap) {
    size_t i = 0u;
    size_t o = 0u;
    while (i < len) {
        const uint8_t code = in[i++];
        if (code == 0u || i + (size_t)code - 1u > len) {
            return -1;
        }
        for (uint8_t k = 1u; k < code; k++) {
            if (in[i] == 0u || o >= cap) {
                return -1;
            }
            out[o++] = in[i++];
        }
        if (code != 0xFFu && i < len) {
            if (o >= cap) {
                return -1;
            }
            out[o++] = 0u;
        }
    }
    return (int32_t)o;
}
