#include "veml3328.h"

int32_t veml3328_it_code(uint16_t integration_ms) {
    static const uint16_t k_it_ms[VEML3328_CONF_IT_COUNT] = VEML3328_CONF_IT_VALUES;
    for (uint32_t code = 0u; code < VEML3328_CONF_IT_COUNT; code++) {
        if (k_it_ms[code] == integration_ms) {
            return (int32_t)code;
        }
    }
    return -1;
}

uint16_t veml3328_conf_word(const veml3328_settings_t *s, bool trigger) {
    uint16_t w = VEML3328_CONF_AF;
    w |= (uint16_t)((s->dg & 0x3u) << VEML3328_CONF_DG_SHIFT);
    w |= (uint16_t)((s->gain & 0x3u) << VEML3328_CONF_GAIN_SHIFT);
    w |= (uint16_t)((s->it_code & 0x3u) << VEML3328_CONF_IT_SHIFT);
    if (s->sens_low != 0u) {
        w |= VEML3328_CONF_SENS;
    }
    if (trigger) {
        w |= VEML3328_CONF_TRIG;
    }
    return w;
}

int32_t veml3328_read_reg(const stac_hal_t *hal, uint8_t bus, uint8_t reg, uint16_t *value) {
    uint8_t rd[2] = {0u, 0u};
    const int32_t rc = hal->i2c_transfer(hal->ctx, bus, VEML3328_ADDR, &reg, 1u, rd, 2u,
                                         VEML3328_TIMEOUT_US);
    if (rc == STAC_I2C_OK) {
        *value = (uint16_t)(rd[0] | (rd[1] << 8));
    }
    return rc;
}

int32_t veml3328_write_reg(const stac_hal_t *hal, uint8_t bus, uint8_t reg, uint16_t value) {
    const uint8_t wr[3] = {reg, (uint8_t)value, (uint8_t)(value >> 8)};
    return hal->i2c_transfer(hal->ctx, bus, VEML3328_ADDR, wr, 3u, (uint8_t *)0, 0u,
                             VEML3328_TIMEOUT_US);
}

int32_t veml3328_probe(const stac_hal_t *hal, uint8_t bus) {
    uint16_t id = 0u;
    const int32_t rc = veml3328_read_reg(hal, bus, VEML3328_REG_ID, &id);
    if (rc != STAC_I2C_OK) {
        return rc;
    }
    return (id & 0xFFu) == VEML3328_ID_LOW ? STAC_I2C_OK : VEML3328_WRONG_ID;
}

int32_t veml3328_configure(const stac_hal_t *hal, uint8_t bus, const veml3328_settings_t *s) {
    return veml3328_write_reg(hal, bus, VEML3328_REG_CONF, veml3328_conf_word(s, false));
}

int32_t veml3328_trigger(const stac_hal_t *hal, uint8_t bus, const veml3328_settings_t *s) {
    return veml3328_write_reg(hal, bus, VEML3328_REG_CONF, veml3328_conf_word(s, true));
}

int32_t veml3328_poll_done(const stac_hal_t *hal, uint8_t bus, bool *done) {
    uint16_t conf = 0u;
    const int32_t rc = veml3328_read_reg(hal, bus, VEML3328_REG_CONF, &conf);
    if (rc == STAC_I2C_OK) {
        *done = (conf & VEML3328_CONF_TRIG) == 0u;
    }
    return rc;
}

int32_t veml3328_read_channels(const stac_hal_t *hal, uint8_t bus,
                               uint16_t counts[VEML3328_CHANNELS], bool *saturated) {
    static const uint8_t k_regs[VEML3328_CHANNELS] = {
        VEML3328_REG_R, VEML3328_REG_G, VEML3328_REG_B, VEML3328_REG_C, VEML3328_REG_IR,
    };
    bool sat = false;
    for (uint32_t ch = 0u; ch < VEML3328_CHANNELS; ch++) {
        uint16_t v = 0u;
        const int32_t rc = veml3328_read_reg(hal, bus, k_regs[ch], &v);
        if (rc != STAC_I2C_OK) {
            return rc;
        }
        counts[ch] = v;
        sat = sat || v == 0xFFFFu;
    }
    *saturated = sat;
    return STAC_I2C_OK;
}

int32_t veml3328_shutdown(const stac_hal_t *hal, uint8_t bus) {
    return veml3328_write_reg(hal, bus, VEML3328_REG_CONF, VEML3328_CONF_SD);
}
