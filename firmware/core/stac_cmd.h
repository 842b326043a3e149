/* Command handling: one received frame in, at most one reply out (ACK, NACK or the answer).
 * Corrupted frames are counted in STATUS.rx_errors and get no reply; anything decodable but
 * unacceptable gets a NACK naming the error and, for CONFIGURE, the offending field. */
#ifndef STAC_CMD_H
#define STAC_CMD_H

#include <stddef.h>
#include <stdint.h>

#include "stac_state.h"

/* Handle the COBS bytes of one received frame (delimiter excluded). */
void stac_cmd_handle(stac_app_t *app, const uint8_t *encoded, size_t len);

#endif /* STAC_CMD_H */
