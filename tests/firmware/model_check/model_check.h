/* Model check: feeds recorded samples through the on-device decoder (stac_model.c) and
 * writes every estimate, so that tests compare it sample by sample with the Python decoder.
 * The same loop runs natively (model_check_native.c: files, ASan + UBSan) and on a
 * Cortex-M4F under QEMU (model_check_qemu.c: semihosting, SysTick cycle stamps).
 *
 * Input: records of MC_IN_SIZE bytes: led_step u8, sensor_status u8[3], counts u16[3][5]
 * (little-endian); a record whose led_step is MC_TARE_STEP calls stac_model_tare (the TARE
 * command) and gives no output. Output: one MC_OUT_SIZE record per input (see mc_record_t), then one
 * trailer record (ret = MC_TRAILER) holding the reference timings. */
#ifndef MODEL_CHECK_H
#define MODEL_CHECK_H

#include <stdint.h>

#define MC_IN_SIZE 34u
#define MC_TRAILER (-2)
#define MC_TARE_STEP 0xFEu /* an input record that tares instead of a sample */
#define MC_REF_LEN 1024u     /* multiply-adds of the reference dot product */
#define MC_CALIB_ITERS 4096u /* iterations of the two-instruction calibration loop */

typedef struct {
    int32_t ret;      /* stac_model_push's result; MC_TRAILER in the trailer */
    uint32_t flags;   /* EST_* (trailer: ticks of the calibration loop) */
    uint32_t region;  /* (trailer: MC_REF_LEN) */
    uint32_t ticks;   /* SysTick ticks spent in stac_model_push (trailer: reference dot) */
    float force[3], torque[3], region_prob, contact_prob;
    float out[32];    /* every output of the decoder, in its order (STAC_MODEL_MAX_OUTPUTS) */
} mc_record_t;

#define MC_OUT_SIZE ((uint32_t)sizeof(mc_record_t))

/* Provided by each platform. */
uint32_t mc_read(uint8_t *buf, uint32_t n);        /* next input bytes; 0 at the end */
void mc_write(const uint8_t *buf, uint32_t n);     /* output bytes */
uint32_t mc_ticks(void);                           /* down-counting 24-bit timer (0: none) */
uint32_t mc_calibrate(uint32_t iterations);        /* ticks of a 2-instruction loop */

/* Opens the image and runs every input record; returns 0, or 2 when the image does not
 * open (nothing is written then). */
int mc_run(const uint8_t *image, uint32_t size);

#endif /* MODEL_CHECK_H */
