/* Consistent Overhead Byte Stuffing (Cheshire & Baker): removes every 0x00 from a frame so
 * that 0x00 can delimit frames on the wire and a receiver resynchronises at the next one. */
#ifndef STAC_COBS_H
#define STAC_COBS_H

#include <stddef.h>
#include <stdint.h>

/* Worst-case encoded size of len bytes (no delimiter). */
#define STAC_COBS_MAX_ENCODED(len) ((len) + (len) / 254u + 1u)

/* Encode len bytes from in into out (capacity cap). Returns the encoded length, or 0 when
 * out is too small. in and out must not overlap. */
size_t stac_cobs_encode(const uint8_t *in, size_t len, uint8_t *out, size_t cap);

/* Decode len COBS bytes (without delimiter) into out (capacity cap). Returns the decoded
 * length, or -1 for malformed input (a zero byte, a block running past the end) or overflow. */
int32_t stac_cobs_decode(const uint8_t *in, size_t len, uint8_t *out, size_t cap);

#endif /* STAC_COBS_H */
