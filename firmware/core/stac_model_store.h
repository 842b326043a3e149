/* Model store: the decoder the device runs, uploaded into the HAL's flash region
 * (MODEL_BEGIN / MODEL_CHUNK / MODEL_COMMIT / MODEL_CLEAR) or compiled in (STAC_BUILTIN_MODEL).
 *
 * Flash layout (capacity C of the HAL's region):
 *   [0, size)             the model image, exactly as uploaded
 *   [C - 64, C - 44)      commit record: model_id, size, crc (CRC-32C of the image), check
 *                         (CRC-32C of those 12 bytes), magic STAC_STORE_MAGIC
 * The record is programmed last, and its magic word after the rest of it, so an upload cut
 * short (power loss, reset, a failed write) never leaves a record that validates. MODEL_BEGIN
 * clears the magic word (programming only clears bits, so that works on any content) before
 * it erases, so the old model is gone even if the erase fails. MODEL_BEGIN erases only what
 * the new image needs: [0, size) and the record area (unless erasing the image already erased
 * it: a port erasing whole sectors clears the record's sector with an image reaching into it);
 * bytes past the image may keep older contents, which no record ever covers. MODEL_CLEAR
 * erases the whole region. At boot the record, the image's CRC and stac_model_open all have
 * to agree before the model is used.
 *
 * Chunks arrive at any length; flash takes whole words, so up to three bytes wait in RAM until
 * the next chunk (or MODEL_COMMIT, which pads the last word with 0xFF). */
#ifndef STAC_MODEL_STORE_H
#define STAC_MODEL_STORE_H

#include <stdbool.h>
#include <stdint.h>

#include "stac_hal.h"
#include "stac_model.h"

#define STAC_STORE_MAGIC 0x52544D53u /* "SMTR" little-endian: a committed model follows */
#define STAC_STORE_RECORD_AREA 64u   /* reserved for the record at the region end (MAX_IMAGE_BYTES) */
#define STAC_STORE_MAX_CHUNK 224u
/* Bytes the CRC pass covers between two watchdog refreshes (~1.4 ms at 96 MHz). */
#define STAC_STORE_CRC_BLOCK 8192u

/* MODEL_INFO.present */
enum {
    STAC_STORE_NONE = 0,     /* no model */
    STAC_STORE_UPLOADED = 1, /* a committed upload in the flash region */
    STAC_STORE_BUILTIN = 2   /* the image compiled into the firmware */
};

typedef struct stac_model_store {
    /* The model in use. */
    uint8_t present;   /* STAC_STORE_* */
    uint32_t model_id; /* uploaded: MODEL_BEGIN's; built-in: the image's own */
    uint32_t size, crc;
    stac_model_t model; /* opened image (valid when present != NONE) */

    /* The upload in progress. */
    bool receiving;
    uint32_t up_id, up_size, up_crc;
    uint32_t received;     /* bytes accepted so far */
    uint8_t staged[4];     /* the bytes past the last whole word written */
    uint8_t staged_len;
} stac_model_store_t;

/* Largest image MODEL_BEGIN accepts: the region less the record (0 without a region). */
uint32_t stac_store_capacity(const stac_hal_t *hal);

/* Boot (and every reset): use the committed upload if its record, CRC and image all check,
 * else the built-in model if the firmware has one, else none. No upload is in progress. */
void stac_store_boot(stac_model_store_t *s, const stac_hal_t *hal);

/* Each returns STAC_OK or the NACK code of hardware/definitions/messages.toml. */
uint16_t stac_store_begin(stac_model_store_t *s, const stac_hal_t *hal, uint32_t model_id,
                          uint32_t size, uint32_t crc);
uint16_t stac_store_chunk(stac_model_store_t *s, const stac_hal_t *hal, uint32_t offset,
                          const uint8_t *data, uint32_t len);
uint16_t stac_store_commit(stac_model_store_t *s, const stac_hal_t *hal, uint32_t model_id);
uint16_t stac_store_clear(stac_model_store_t *s, const stac_hal_t *hal);

/* End the upload in progress, if any (a MODEL_CHUNK refused before it reached the store). */
void stac_store_end_upload(stac_model_store_t *s);

/* The model in use, or NULL. */
const stac_model_t *stac_store_model(const stac_model_store_t *s);

#endif /* STAC_MODEL_STORE_H */
