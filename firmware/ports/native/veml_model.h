/* Register-level VEML3328 model for the native port: a test double of the sensor on its bus.
 *
 * Same behaviour as the Python twin's model (host/spectratac/twin/veml3328.py, the reference;
 * tests compare the two transfer by transfer): CONF 0x00 (the only writable register), data
 * C 0x04, R 0x05, G 0x06, B 0x07, IR 0x08, ID 0x0C; active-force triggers, continuous mode,
 * shutdown, register pointer, 0xFF past the second byte read, NACK for what the part refuses.
 * The counts of a completed integration window come from a callback (the twin computes them);
 * the model only keeps the register state, so the firmware's many register reads of one window
 * cost no call into the twin. Times are 64-bit microseconds and never run backwards. */
#ifndef VEML_MODEL_H
#define VEML_MODEL_H

#include <stdint.h>

#include "generated/veml3328_regs.h"

#define VEML_MODEL_CHANNELS 5u /* R, G, B, C, IR: the twin's channel order */
#define VEML_MODEL_OK 0
#define VEML_MODEL_NACK 1
#define VEML_MODEL_BUS_ERROR 3

/* CONF bits (hardware/definitions/veml3328.toml). */
#define VEML_MODEL_SD0 VEML3328_CONF_SD0
#define VEML_MODEL_TRIG VEML3328_CONF_TRIG
#define VEML_MODEL_AF VEML3328_CONF_AF
#define VEML_MODEL_SENS VEML3328_CONF_SENS
#define VEML_MODEL_SD_ALS VEML3328_CONF_SD_ALS
#define VEML_MODEL_SD1 VEML3328_CONF_SD1
#define VEML_MODEL_CONF_MASK VEML3328_CONF_DEFINED /* bits that exist; reserved ones read back 0 */
/* CONF bits that shape a window's counts: IT, SENS, gain, DG, SD_ALS. */
#define VEML_MODEL_WINDOW_BITS VEML3328_CONF_WINDOW

/* Counts (R, G, B, C, IR) of sensor `index` for the window [t0, t1) under CONF `conf`;
 * return 0, or nonzero when the twin failed (the transfer then reports a bus error). */
typedef int32_t (*veml_model_window_fn)(void *ctx, uint8_t index, uint64_t t0_us,
                                        uint64_t t1_us, uint16_t conf,
                                        uint16_t counts[VEML_MODEL_CHANNELS],
                                        uint8_t *saturated);

typedef struct veml_model {
    uint64_t now;        /* bus clock: the latest transfer time */
    uint64_t pend_t0;    /* active-force integration in progress */
    uint64_t pend_t1;
    uint64_t cont_start; /* start of the back-to-back cycle (AF = 0) */
    int64_t cont_done;   /* index of the last stored continuous window */
    uint32_t completed;  /* completed integrations */
    uint16_t conf;
    uint16_t pend_conf;  /* CONF at the trigger */
    uint16_t data[VEML_MODEL_CHANNELS]; /* R, G, B, C, IR */
    uint8_t index;
    uint8_t pointer;
    uint8_t present;
    uint8_t saturated;
    uint8_t has_pending;
    uint8_t has_cont;
    veml_model_window_fn window;
    void *ctx;
} veml_model_t;

/* Power-up state (shut down, CONF = 0x8001) for sensor `index`. */
void veml_model_init(veml_model_t *m, uint8_t index, uint8_t present, veml_model_window_fn window,
                     void *ctx);

/* One I2C transaction at `now_us`: write wr_len bytes, then read rd_len bytes into rd.
 * Returns VEML_MODEL_OK, VEML_MODEL_NACK or VEML_MODEL_BUS_ERROR (the window callback failed). */
int32_t veml_model_transfer(veml_model_t *m, uint64_t now_us, const uint8_t *wr, uint32_t wr_len,
                            uint8_t *rd, uint32_t rd_len);

#endif /* VEML_MODEL_H */
