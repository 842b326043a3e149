#include "i2c.h"

#include "generated/board.h"
#include "gpio.h"
#include "host_link.h"
#include "regs.h"
#include "stac_hal.h"
#include "timebase.h"

#define I2C_HZ 400000u

static i2c_t *const k_i2c[3] = {I2C1, I2C2, I2C3};
static uint32_t g_apb1_hz;

static void i2c_setup(i2c_t *i2c) {
    const uint32_t mhz = g_apb1_hz / 1000000u;
    i2c->CR1 = I2C_CR1_SWRST;
    i2c->CR1 = 0u;
    i2c->CR2 = mhz;
    /* Fast mode, duty 2:1: period = 3 * CCR / f_pclk. */
    uint32_t ccr = (g_apb1_hz + 3u * I2C_HZ - 1u) / (3u * I2C_HZ);
    if (ccr < 1u) {
        ccr = 1u;
    }
    i2c->CCR = I2C_CCR_FS | ccr;
    i2c->TRISE = mhz * 300u / 1000u + 1u; /* 300 ns maximum rise time */
    i2c->CR1 = I2C_CR1_PE;
}

void i2c_init_all(uint32_t apb1_hz) {
    g_apb1_hz = apb1_hz;
    RCC->APB1ENR |= RCC_APB1ENR_I2C1 | RCC_APB1ENR_I2C2 | RCC_APB1ENR_I2C3;
    (void)RCC->APB1ENR;
    for (uint32_t b = 0; b < 3u; b++) {
        i2c_setup(k_i2c[b]);
    }
}

/* A slave interrupted mid-byte can hold SDA low for ever: up to nine SCL pulses and a STOP
 * by hand release it (UM10204 3.1.16). Bounded: 9 pulses of ~10 µs. */
static void bus_clear(uint8_t bus) {
    const board_pin_t *scl = &k_board_pins[2u * bus];
    const board_pin_t *sda = &k_board_pins[2u * bus + 1u];
    gpio_t *scl_port = gpio_port(scl->port);
    gpio_t *sda_port = gpio_port(sda->port);
    gpio_od_out(scl_port, scl->pin, 1);
    gpio_od_out(sda_port, sda->pin, 1);
    for (uint32_t i = 0; i < 9u && !gpio_read(sda_port, sda->pin); i++) {
        uint32_t t = timebase_now_us();
        gpio_write(scl_port, scl->pin, 0);
        while (timebase_now_us() - t < 5u) {
        }
        t = timebase_now_us();
        gpio_write(scl_port, scl->pin, 1);
        while (timebase_now_us() - t < 5u) {
        }
    }
    /* STOP: SDA rises while SCL is high. */
    gpio_write(sda_port, sda->pin, 0);
    const uint32_t t = timebase_now_us();
    while (timebase_now_us() - t < 5u) {
    }
    gpio_write(sda_port, sda->pin, 1);
    gpio_af(scl_port, scl->pin, scl->af, 1, 1);
    gpio_af(sda_port, sda->pin, sda->af, 1, 1);
}

static void recover(uint8_t bus) {
    i2c_t *i2c = k_i2c[bus];
    i2c->CR1 = 0u;
    bus_clear(bus);
    i2c_setup(i2c);
}

/* Wait until (SR1 & mask) != 0. Returns OK, NACK (AF), BUS_ERROR or TIMEOUT. Keeps the UART
 * transmitter fed meanwhile, so frames flow even while a bus is slow. */
static int32_t wait_sr1(i2c_t *i2c, uint32_t mask, uint32_t t0, uint32_t timeout_us) {
    for (;;) {
        const uint32_t sr1 = i2c->SR1;
        if ((sr1 & I2C_SR1_AF) != 0u) {
            return STAC_I2C_NACK;
        }
        if ((sr1 & (I2C_SR1_BERR | I2C_SR1_ARLO)) != 0u) {
            return STAC_I2C_BUS_ERROR;
        }
        if ((sr1 & mask) != 0u) {
            return STAC_I2C_OK;
        }
        if (timebase_now_us() - t0 >= timeout_us) {
            return STAC_I2C_TIMEOUT;
        }
        host_link_service();
    }
}

static int32_t wait_clear(volatile uint32_t *reg, uint32_t mask, uint32_t t0, uint32_t timeout_us) {
    while ((*reg & mask) != 0u) {
        if (timebase_now_us() - t0 >= timeout_us) {
            return STAC_I2C_TIMEOUT;
        }
        host_link_service();
    }
    return STAC_I2C_OK;
}

static int32_t address(i2c_t *i2c, uint8_t addr_rw, uint32_t t0, uint32_t timeout_us) {
    i2c->CR1 |= I2C_CR1_START;
    int32_t rc = wait_sr1(i2c, I2C_SR1_SB, t0, timeout_us);
    if (rc != STAC_I2C_OK) {
        return rc;
    }
    i2c->DR = addr_rw;
    return wait_sr1(i2c, I2C_SR1_ADDR, t0, timeout_us);
}

static int32_t do_transfer(i2c_t *i2c, uint8_t addr7, const uint8_t *wr, uint32_t wr_len,
                           uint8_t *rd, uint32_t rd_len, uint32_t t0, uint32_t timeout_us) {
    int32_t rc = wait_clear(&i2c->SR2, I2C_SR2_BUSY, t0, timeout_us);
    if (rc != STAC_I2C_OK) {
        return rc;
    }
    if (wr_len > 0u) {
        rc = address(i2c, (uint8_t)(addr7 << 1), t0, timeout_us);
        if (rc != STAC_I2C_OK) {
            return rc;
        }
        (void)i2c->SR2; /* reading SR1 then SR2 clears ADDR */
        for (uint32_t i = 0; i < wr_len; i++) {
            rc = wait_sr1(i2c, I2C_SR1_TXE, t0, timeout_us);
            if (rc != STAC_I2C_OK) {
                return rc;
            }
            i2c->DR = wr[i];
        }
        rc = wait_sr1(i2c, I2C_SR1_BTF, t0, timeout_us);
        if (rc != STAC_I2C_OK) {
            return rc;
        }
    }
    if (rd_len == 0u) {
        i2c->CR1 |= I2C_CR1_STOP;
        return STAC_I2C_OK;
    }
    /* Repeated start, then the reference-manual sequences for 1, 2 and N > 2 bytes. */
    i2c->CR1 |= I2C_CR1_ACK;
    if (rd_len == 2u) {
        i2c->CR1 |= I2C_CR1_POS;
    }
    rc = address(i2c, (uint8_t)((addr7 << 1) | 1u), t0, timeout_us);
    if (rc != STAC_I2C_OK) {
        return rc;
    }
    if (rd_len == 1u) {
        i2c->CR1 &= ~I2C_CR1_ACK;
        (void)i2c->SR2;
        i2c->CR1 |= I2C_CR1_STOP;
        rc = wait_sr1(i2c, I2C_SR1_RXNE, t0, timeout_us);
        if (rc == STAC_I2C_OK) {
            rd[0] = (uint8_t)i2c->DR;
        }
        return rc;
    }
    if (rd_len == 2u) {
        (void)i2c->SR2;
        i2c->CR1 &= ~I2C_CR1_ACK;
        rc = wait_sr1(i2c, I2C_SR1_BTF, t0, timeout_us);
        if (rc != STAC_I2C_OK) {
            return rc;
        }
        i2c->CR1 |= I2C_CR1_STOP;
        rd[0] = (uint8_t)i2c->DR;
        rd[1] = (uint8_t)i2c->DR;
        i2c->CR1 &= ~I2C_CR1_POS;
        return STAC_I2C_OK;
    }
    (void)i2c->SR2;
    for (uint32_t i = 0; i < rd_len; i++) {
        if (i == rd_len - 3u) {
            /* Bytes N-2 and N-1 are in DR and the shift register: NACK the last, then STOP. */
            rc = wait_sr1(i2c, I2C_SR1_BTF, t0, timeout_us);
            if (rc != STAC_I2C_OK) {
                return rc;
            }
            i2c->CR1 &= ~I2C_CR1_ACK;
            rd[i++] = (uint8_t)i2c->DR;
            rc = wait_sr1(i2c, I2C_SR1_BTF, t0, timeout_us);
            if (rc != STAC_I2C_OK) {
                return rc;
            }
            i2c->CR1 |= I2C_CR1_STOP;
            rd[i++] = (uint8_t)i2c->DR;
            rc = wait_sr1(i2c, I2C_SR1_RXNE, t0, timeout_us);
            if (rc == STAC_I2C_OK) {
                rd[i] = (uint8_t)i2c->DR;
            }
            return rc;
        }
        rc = wait_sr1(i2c, I2C_SR1_RXNE, t0, timeout_us);
        if (rc != STAC_I2C_OK) {
            return rc;
        }
        rd[i] = (uint8_t)i2c->DR;
    }
    return STAC_I2C_OK;
}

int32_t i2c_transfer(uint8_t bus, uint8_t addr7, const uint8_t *wr, uint32_t wr_len, uint8_t *rd,
                     uint32_t rd_len, uint32_t timeout_us) {
    if (bus > 2u || (wr_len == 0u && rd_len == 0u)) {
        return STAC_I2C_BUS_ERROR;
    }
    i2c_t *i2c = k_i2c[bus];
    const uint32_t t0 = timebase_now_us();
    const int32_t rc = do_transfer(i2c, addr7, wr, wr_len, rd, rd_len, t0, timeout_us);
    if (rc == STAC_I2C_NACK) {
        /* Release the bus and clear the flag; the peripheral itself is fine. */
        i2c->CR1 |= I2C_CR1_STOP;
        i2c->SR1 = ~I2C_SR1_AF;
        i2c->CR1 &= ~I2C_CR1_POS;
    } else if (rc != STAC_I2C_OK) {
        recover(bus);
    } else {
        /* Let the STOP go out so the next START is not refused as BUSY; bounded like the rest. */
        (void)wait_clear(&i2c->CR1, I2C_CR1_STOP, t0, timeout_us);
    }
    return rc;
}
