/* CRC-32C (Castagnoli) as the protocol fixes it: reflected polynomial 0x82F63B78, init and
 * xorout 0xFFFFFFFF; check value of "123456789" is 0xE3069283. */
#ifndef STAC_CRC32C_H
#define STAC_CRC32C_H

#include <stddef.h>
#include <stdint.h>

/* CRC over a whole frame including its own little-endian CRC (the residue). */
#define STAC_CRC32C_RESIDUE 0x48674BC7u

/* Continue a CRC: start with crc = 0 for a fresh computation. */
uint32_t stac_crc32c_update(uint32_t crc, const uint8_t *data, size_t len);

static inline uint32_t stac_crc32c(const uint8_t *data, size_t len) {
    return stac_crc32c_update(0u, data, len);
}

#endif /* STAC_CRC32C_H */
