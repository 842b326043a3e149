/* Frames as the protocol defines them: header [major, minor, type, seq LE] + payload +
 * CRC-32C LE, COBS-encoded, then one 0x00 delimiter; at most STAC_MAX_FRAME bytes on the wire. */
#ifndef STAC_FRAME_H
#define STAC_FRAME_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "generated/stac_messages.h"

/* COBS bytes between delimiters, and decoded bytes, of the largest legal frame. */
#define STAC_MAX_ENCODED (STAC_MAX_FRAME - 1u)
#define STAC_MAX_DECODED (STAC_HEADER_SIZE + STAC_MAX_PAYLOAD + STAC_CRC_SIZE)
#define STAC_MIN_DECODED (STAC_HEADER_SIZE + STAC_CRC_SIZE)

/* Why a received frame was dropped (names as in the golden vectors). */
typedef enum stac_frame_status {
    STAC_FRAME_OK = 0,
    STAC_FRAME_BAD_COBS,
    STAC_FRAME_TOO_SHORT,
    STAC_FRAME_OVERSIZE,
    STAC_FRAME_BAD_CRC
} stac_frame_status_t;

typedef struct stac_frame_header {
    uint8_t major;
    uint8_t minor;
    uint8_t type;
    uint16_t seq;
} stac_frame_header_t;

/* Encode one frame (protocol version of this firmware) into out, delimiter included.
 * Returns the number of bytes, or 0 if the payload is longer than STAC_MAX_PAYLOAD or out
 * (capacity cap) is too small; STAC_MAX_FRAME bytes always suffice. */
size_t stac_frame_encode(uint8_t type, uint16_t seq, const uint8_t *payload, size_t len,
                         uint8_t *out, size_t cap);

/* Same with an explicit version (tests and vectors of other versions). */
size_t stac_frame_encode_version(uint8_t major, uint8_t minor, uint8_t type, uint16_t seq,
                                 const uint8_t *payload, size_t len, uint8_t *out, size_t cap);

/* Decode the COBS bytes of one frame (delimiter excluded) into raw (STAC_MAX_DECODED bytes),
 * check length and CRC, and on success fill hdr and point *payload / *payload_len into raw. */
stac_frame_status_t stac_frame_decode(const uint8_t *encoded, size_t len,
                                      uint8_t raw[STAC_MAX_DECODED], stac_frame_header_t *hdr,
                                      const uint8_t **payload, size_t *payload_len);

/* Byte-stream accumulator: collects the bytes between 0x00 delimiters and survives garbage.
 * A run longer than STAC_MAX_ENCODED is discarded up to its delimiter and reported once. */
typedef struct stac_rx {
    uint8_t buf[STAC_MAX_ENCODED];
    uint16_t len;
    bool overflow; /* inside a run too long to be a frame: skip to its delimiter */
    bool closed;   /* buf holds a complete frame; the next byte starts a new one */
} stac_rx_t;

typedef enum stac_rx_event {
    STAC_RX_NONE = 0,     /* byte consumed, no frame boundary */
    STAC_RX_FRAME,        /* a delimiter closed a frame: buf[0..len) holds its COBS bytes
                           * until the next push */
    STAC_RX_OVERSIZE      /* a delimiter closed a run too long to be a frame */
} stac_rx_event_t;

void stac_rx_reset(stac_rx_t *rx);
stac_rx_event_t stac_rx_push(stac_rx_t *rx, uint8_t byte);

#endif /* STAC_FRAME_H */
