/* Polling I2C master on I2C1..3 (sensor k on bus k), 400 kHz. Every flag wait is bounded by
 * the caller's timeout. The bus is clocked free at init and whenever BUSY stays set; a spurious
 * bus error is cleared and the transfer continues; arbitration loss or a failed transfer resets
 * the peripheral and tries again while the timeout allows. */
#ifndef I2C_H
#define I2C_H

#include <stdint.h>

void i2c_init_all(uint32_t apb1_hz);

/* STAC_I2C_* result; see stac_hal_t.i2c_transfer. */
int32_t i2c_transfer(uint8_t bus, uint8_t addr7, const uint8_t *wr, uint32_t wr_len, uint8_t *rd,
                     uint32_t rd_len, uint32_t timeout_us);

#endif /* I2C_H */
