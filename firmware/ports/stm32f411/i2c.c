#include "i2c.h"

#include <stdbool.h>

#include "generated/board.h"
#include "gpio.h"
#include "host_link.h"
#include "irq.h"
#include "regs.h"
#include "stac_hal.h"
#include "timebase.h"

#define I2C_HZ 400000u
/* Digital noise filter (I2C_FLTR.DNF, in APB1 clocks, 0..15) on top of the analog one: spikes
 * up to ~100 ns are ignored; at 48 MHz that is 4 clocks, which also lengthen each SCL phase
 * by as much, so the bus runs a little under 400 kHz (RM0383 18.6.10). */
#define I2C_FILTER_NS 100u
/* BUSY may stay set this long after a STOP before the bus counts as stuck (~4 byte times). */
#define I2C_BUSY_STUCK_US 100u
/* Attempts per transfer after arbitration loss or a cleared bus, all within the timeout. */
#define I2C_ATTEMPTS 3u
/* Internal result: arbitration lost (no other master exists: noise); cleared and retried. */
#define I2C_ARLO 100

static i2c_t *const k_i2c[3] = {I2C1, I2C2, I2C3};
static uint32_t g_apb1_hz;

/* Configure with the peripheral disabled: CCR, TRISE and FLTR may only change while PE = 0. */
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
    uint32_t dnf = mhz * I2C_FILTER_NS / 1000u;
    if (dnf > I2C_FLTR_DNF_MASK) {
        dnf = I2C_FLTR_DNF_MASK;
    }
    i2c->FLTR = dnf & ~I2C_FLTR_ANOFF; /* ANOFF = 0: the analog filter stays on */
    i2c->CR1 = I2C_CR1_PE;
}

static void wait_us(uint32_t us) {
    const uint32_t t = timebase_now_us();
    while (timebase_now_us() - t < us) {
    }
}

/* A slave interrupted mid-byte (a reset during a read) holds SDA low until it has clocked out
 * its byte: up to nine SCL pulses by hand walk it to its acknowledge slot, where it lets go,
 * then a STOP (UM10204 3.1.16). Run with the peripheral disabled. Bounded: ~100 us. */
static void bus_clear(uint8_t bus) {
    const board_pin_t *scl = &k_board_pins[2u * bus];
    const board_pin_t *sda = &k_board_pins[2u * bus + 1u];
    gpio_t *scl_port = gpio_port(scl->port);
    gpio_t *sda_port = gpio_port(sda->port);
    gpio_od_out(scl_port, scl->pin, 1);
    gpio_od_out(sda_port, sda->pin, 1);
    wait_us(5u);
    for (uint32_t i = 0; i < 9u && !gpio_read(sda_port, sda->pin); i++) {
        gpio_write(scl_port, scl->pin, 0);
        wait_us(5u);
        gpio_write(scl_port, scl->pin, 1);
        wait_us(5u);
    }
    /* STOP: SDA low with SCL low, SCL up, then SDA up while SCL is high. */
    gpio_write(scl_port, scl->pin, 0);
    wait_us(5u);
    gpio_write(sda_port, sda->pin, 0);
    wait_us(5u);
    gpio_write(scl_port, scl->pin, 1);
    wait_us(5u);
    gpio_write(sda_port, sda->pin, 1);
    wait_us(5u);
    gpio_af(scl_port, scl->pin, scl->af, 1, 1);
    gpio_af(sda_port, sda->pin, sda->af, 1, 1);
}

static void recover(uint8_t bus) {
    i2c_t *i2c = k_i2c[bus];
    i2c->CR1 = 0u;
    bus_clear(bus);
    i2c_setup(i2c);
}

void i2c_init_all(uint32_t apb1_hz) {
    g_apb1_hz = apb1_hz;
    RCC->APB1ENR |= RCC_APB1ENR_I2C1 | RCC_APB1ENR_I2C2 | RCC_APB1ENR_I2C3;
    (void)RCC->APB1ENR;
    for (uint8_t b = 0; b < 3u; b++) {
        /* A sensor still sending from before our reset would otherwise read as absent. */
        recover(b);
    }
}

/* Wait until (SR1 & mask) != 0. Returns OK, NACK (AF), I2C_ARLO, BUS_ERROR or TIMEOUT. A bus
 * error is cleared and the wait goes on: in master mode ST's errata ES0287 lists spurious BERR
 * detection with no effect on the transfer. Keeps the host link fed meanwhile. */
static int32_t wait_sr1(i2c_t *i2c, uint32_t mask, uint32_t t0, uint32_t timeout_us) {
    for (;;) {
        const uint32_t sr1 = i2c->SR1;
        if ((sr1 & I2C_SR1_AF) != 0u) {
            return STAC_I2C_NACK;
        }
        if ((sr1 & I2C_SR1_ARLO) != 0u) {
            return I2C_ARLO;
        }
        if ((sr1 & I2C_SR1_BERR) != 0u) {
            i2c->SR1 = ~I2C_SR1_BERR; /* rc_w0: only BERR is cleared */
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

/* Wait for a free bus. BUSY that outlasts a STOP by I2C_BUSY_STUCK_US means a slave holds a
 * line: clear the bus (once per call) and look again. */
static int32_t wait_idle(uint8_t bus, uint32_t t0, uint32_t timeout_us) {
    i2c_t *i2c = k_i2c[bus];
    const uint32_t since = timebase_now_us();
    bool cleared = false;
    while ((i2c->SR2 & I2C_SR2_BUSY) != 0u) {
        const uint32_t now = timebase_now_us();
        if (now - t0 >= timeout_us) {
            return STAC_I2C_TIMEOUT;
        }
        if (!cleared && now - since >= I2C_BUSY_STUCK_US) {
            recover(bus);
            cleared = true;
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
    int32_t rc;
    i2c->CR1 &= ~(I2C_CR1_POS | I2C_CR1_ACK);
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
    /* Repeated start, then RM0383 18.3.3's sequences for 1, 2 and N > 2 bytes. ACK (and POS
     * for two bytes) are set before the address goes out; the steps that must follow the
     * clearing of ADDR before the current byte's acknowledge pulse run with interrupts
     * masked, so a USB or SysTick interrupt cannot make them late. */
    i2c->CR1 |= rd_len == 2u ? (I2C_CR1_ACK | I2C_CR1_POS) : I2C_CR1_ACK;
    rc = address(i2c, (uint8_t)((addr7 << 1) | 1u), t0, timeout_us);
    if (rc != STAC_I2C_OK) {
        return rc;
    }
    if (rd_len == 1u) {
        i2c->CR1 &= ~I2C_CR1_ACK;
        const uint32_t primask = irq_save();
        (void)i2c->SR2;
        i2c->CR1 |= I2C_CR1_STOP;
        irq_restore(primask);
        rc = wait_sr1(i2c, I2C_SR1_RXNE, t0, timeout_us);
        if (rc == STAC_I2C_OK) {
            rd[0] = (uint8_t)i2c->DR;
        }
        return rc;
    }
    if (rd_len == 2u) {
        const uint32_t primask = irq_save();
        (void)i2c->SR2;
        i2c->CR1 &= ~I2C_CR1_ACK; /* with POS: NACK the second byte */
        irq_restore(primask);
        rc = wait_sr1(i2c, I2C_SR1_BTF, t0, timeout_us);
        if (rc != STAC_I2C_OK) {
            return rc;
        }
        /* Both bytes in (DR and shift register), SCL held low: nothing is late any more. */
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
    int32_t rc = STAC_I2C_TIMEOUT;
    for (uint32_t attempt = 0u; attempt < I2C_ATTEMPTS; attempt++) {
        rc = wait_idle(bus, t0, timeout_us);
        if (rc == STAC_I2C_OK) {
            rc = do_transfer(i2c, addr7, wr, wr_len, rd, rd_len, t0, timeout_us);
        }
        if (rc == STAC_I2C_OK) {
            /* Let the STOP go out so the next START is not refused as BUSY; bounded. */
            (void)wait_clear(&i2c->CR1, I2C_CR1_STOP, t0, timeout_us);
            return rc;
        }
        if (rc == STAC_I2C_NACK) {
            /* Release the bus and clear the flag; the peripheral itself is fine. */
            i2c->CR1 |= I2C_CR1_STOP;
            i2c->SR1 = ~I2C_SR1_AF;
            i2c->CR1 &= ~(I2C_CR1_POS | I2C_CR1_ACK);
            return rc;
        }
        if (rc == I2C_ARLO) {
            /* The peripheral has left master mode by itself; clear the flag, start again. */
            i2c->SR1 = ~I2C_SR1_ARLO;
            rc = STAC_I2C_BUS_ERROR;
        } else {
            recover(bus);
        }
        if (timebase_now_us() - t0 >= timeout_us) {
            break;
        }
    }
    return rc;
}
