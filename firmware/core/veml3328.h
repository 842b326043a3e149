/* Register-level driver for the Vishay VEML3328 RGBCIR colour sensor (7-bit address 0x10).
 * 16-bit registers, little-endian: write [reg, lsb, msb]; read [reg] then repeated start and
 * two bytes. Every call is one or a few bounded HAL transfers; nothing here waits.
 *
 * Checked against hardware/datasheet_facts.toml (Vishay datasheet 84968, Tables 1 and 2; the
 * register and CONF tables agree with the Linux, Microchip and Samsung drivers that cite it):
 * CONF 00h, C/R/G/B/IR 04h-08h, ID 0Ch low byte 0x28; SD0 bit 0 and SD1 bit 15 both clear to
 * run, TRIG bit 2, AF bit 3, IT bits 5:4 = 50/100/200/400 ms, SENS bit 6, GAIN bits 11:10,
 * DG bits 13:12, SD_ALS bit 14. tests/hardware/test_datasheet_facts.py compares
 * hardware/definitions/veml3328.toml (the source of generated/veml3328_regs.h) with those facts.
 *
 * Active force mode: veml3328_configure() writes AF = 1 with both SD bits clear (no
 * measurement yet); veml3328_trigger() rewrites the same word with TRIG = 1, which starts one
 * integration; the caller waits the integration time, then veml3328_poll_done() reads CONF
 * until TRIG reads 0. That the sensor clears TRIG itself is not confirmed from the datasheet
 * (its register description was not reachable): the scheduler polls only after the
 * integration time and stops at a deadline; a sensor still showing TRIG there has it cleared
 * and its data read, and once that proves a new conversion it is read by time from then on
 * (stac_acquisition.c), so neither behaviour leaves it stale or waited on for ever. */
#ifndef VEML3328_H
#define VEML3328_H

#include <stdbool.h>
#include <stdint.h>

#include "stac_hal.h"

/* Register map and CONF bit fields (VEML3328_REG_*, VEML3328_CONF_*), generated from
 * hardware/definitions/veml3328.toml. */
#include "generated/veml3328_regs.h"

/* Channel order of a reading, as in SAMPLE.counts. */
enum { VEML3328_CH_R = 0, VEML3328_CH_G, VEML3328_CH_B, VEML3328_CH_C, VEML3328_CH_IR,
       VEML3328_CHANNELS };

/* Driver results: a STAC_I2C_* code, or this one when a device answers with another ID. */
#define VEML3328_WRONG_ID 16

/* Per-transfer bound: a 3-byte transfer takes ~0.1 ms at 400 kHz and ~0.4 ms at 100 kHz. */
#define VEML3328_TIMEOUT_US 2000u

typedef struct veml3328_settings {
    uint8_t it_code;   /* index into VEML3328_CONF_IT_VALUES (ms) */
    uint8_t gain;      /* 0..3 */
    uint8_t dg;        /* 0..2 */
    uint8_t sens_low;  /* 0 high, 1 low */
} veml3328_settings_t;

/* IT code of an integration time in ms, or -1 if the sensor has no such setting. */
int32_t veml3328_it_code(uint16_t integration_ms);

/* CONF word for the settings: running, active force mode, TRIG as given. */
uint16_t veml3328_conf_word(const veml3328_settings_t *s, bool trigger);

int32_t veml3328_read_reg(const stac_hal_t *hal, uint8_t bus, uint8_t reg, uint16_t *value);
int32_t veml3328_write_reg(const stac_hal_t *hal, uint8_t bus, uint8_t reg, uint16_t value);

/* Read the ID register; STAC_I2C_OK only if its low byte is VEML3328_ID_LOW. */
int32_t veml3328_probe(const stac_hal_t *hal, uint8_t bus);

/* Power up in active force mode with the settings, without starting a measurement. */
int32_t veml3328_configure(const stac_hal_t *hal, uint8_t bus, const veml3328_settings_t *s);

/* Write the settings with TRIG set: one integration starts now. */
int32_t veml3328_trigger(const stac_hal_t *hal, uint8_t bus, const veml3328_settings_t *s);

/* Read CONF; *done is true once the sensor has cleared TRIG (the measurement finished). */
int32_t veml3328_poll_done(const stac_hal_t *hal, uint8_t bus, bool *done);

/* Read R, G, B, C, IR; *saturated is true if any channel reads 65535 (clipped). */
int32_t veml3328_read_channels(const stac_hal_t *hal, uint8_t bus,
                               uint16_t counts[VEML3328_CHANNELS], bool *saturated);

/* Put the sensor into shutdown (both SD bits). */
int32_t veml3328_shutdown(const stac_hal_t *hal, uint8_t bus);

#endif /* VEML3328_H */
