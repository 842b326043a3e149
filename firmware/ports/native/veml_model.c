/* Register-level VEML3328 model; mirrors host/spectratac/twin/veml3328.py step for step. */
#include "veml_model.h"

#include <string.h>

#define REG_CONF VEML3328_REG_CONF
#define REG_C VEML3328_REG_C
#define REG_R VEML3328_REG_R
#define REG_G VEML3328_REG_G
#define REG_B VEML3328_REG_B
#define REG_IR VEML3328_REG_IR
#define REG_ID VEML3328_REG_ID
#define DEVICE_ID VEML3328_ID_LOW /* ID register: part ID low, address option 0 high */
#define POWER_ON_CONF (VEML_MODEL_SD1 | VEML_MODEL_SD0)

void veml_model_init(veml_model_t *m, uint8_t index, uint8_t present, veml_model_window_fn window,
                     void *ctx) {
    memset(m, 0, sizeof *m);
    m->index = index;
    m->present = present;
    m->conf = POWER_ON_CONF;
    m->pointer = REG_CONF;
    m->cont_done = -1;
    m->window = window;
    m->ctx = ctx;
}

static int powered(const veml_model_t *m) {
    return (m->conf & (VEML_MODEL_SD0 | VEML_MODEL_SD1)) == 0u;
}

static uint64_t integration_us(uint16_t conf) {
    static const uint64_t k_it_ms[VEML3328_CONF_IT_COUNT] = VEML3328_CONF_IT_VALUES;
    return k_it_ms[(conf & VEML3328_CONF_IT_MASK) >> VEML3328_CONF_IT_SHIFT] * 1000u;
}

static int readable(uint8_t reg) {
    return reg == REG_CONF || reg == REG_ID || (reg >= REG_C && reg <= REG_IR);
}

/* Data register -> slot in data[] (channel order R, G, B, C, IR). */
static uint32_t slot(uint8_t reg) {
    switch (reg) {
    case REG_R: return 0u;
    case REG_G: return 1u;
    case REG_B: return 2u;
    case REG_C: return 3u;
    default: return 4u; /* REG_IR */
    }
}

static int32_t store(veml_model_t *m, uint64_t t0, uint64_t t1, uint16_t conf) {
    uint16_t counts[VEML_MODEL_CHANNELS] = {0u, 0u, 0u, 0u, 0u};
    uint8_t sat = 0u;
    if (m->window(m->ctx, m->index, t0, t1, conf, counts, &sat) != 0) {
        return VEML_MODEL_BUS_ERROR;
    }
    memcpy(m->data, counts, sizeof m->data);
    m->saturated = sat != 0u ? 1u : 0u;
    m->completed++;
    return VEML_MODEL_OK;
}

static int32_t advance(veml_model_t *m, uint64_t now) {
    if (now < m->now) {
        now = m->now; /* the bus clock never runs backwards; treat as simultaneous */
    }
    m->now = now;
    if (m->has_pending != 0u && now >= m->pend_t1) {
        m->has_pending = 0u;
        m->conf &= (uint16_t)~VEML_MODEL_TRIG;
        const int32_t rc = store(m, m->pend_t0, m->pend_t1, m->pend_conf);
        if (rc != VEML_MODEL_OK) {
            return rc;
        }
    }
    if (m->has_cont != 0u && powered(m) && (m->conf & VEML_MODEL_AF) == 0u) {
        const uint64_t it = integration_us(m->conf);
        const int64_t n = (int64_t)((now - m->cont_start) / it) - 1; /* last completed window */
        if (n > m->cont_done) {
            const uint64_t t0 = m->cont_start + (uint64_t)n * it;
            m->cont_done = n;
            return store(m, t0, t0 + it, m->conf);
        }
    }
    return VEML_MODEL_OK;
}

static void write_conf(veml_model_t *m, uint64_t now, uint16_t value) {
    const uint16_t old = m->conf;
    m->conf = (uint16_t)(value & VEML_MODEL_CONF_MASK);
    if (!powered(m)) {
        m->has_pending = 0u;
        m->has_cont = 0u;
        m->conf &= (uint16_t)~VEML_MODEL_TRIG;
        return;
    }
    if ((m->conf & VEML_MODEL_AF) != 0u) {
        m->has_cont = 0u;
        if ((m->conf & VEML_MODEL_TRIG) != 0u && m->has_pending == 0u) {
            m->has_pending = 1u;
            m->pend_t0 = now;
            m->pend_t1 = now + integration_us(m->conf);
            m->pend_conf = m->conf;
        } else if ((m->conf & VEML_MODEL_TRIG) == 0u) {
            m->has_pending = 0u;
        }
        return;
    }
    m->has_pending = 0u;
    m->conf &= (uint16_t)~VEML_MODEL_TRIG;
    /* Continuous mode: a new cycle starts when the device powers up or its settings change. */
    const uint16_t keep = (uint16_t)~VEML_MODEL_TRIG;
    if (m->has_cont == 0u || (old & keep) != (m->conf & keep)) {
        m->has_cont = 1u;
        m->cont_start = now;
        m->cont_done = -1;
    }
}

static uint16_t read_reg(const veml_model_t *m, uint8_t reg) {
    if (reg == REG_CONF) {
        return m->conf;
    }
    if (reg == REG_ID) {
        return DEVICE_ID;
    }
    return m->data[slot(reg)];
}

int32_t veml_model_transfer(veml_model_t *m, uint64_t now_us, const uint8_t *wr, uint32_t wr_len,
                            uint8_t *rd, uint32_t rd_len) {
    if (m->present == 0u) {
        return VEML_MODEL_NACK;
    }
    const int32_t rc = advance(m, now_us);
    if (rc != VEML_MODEL_OK) {
        return rc;
    }
    if (wr_len > 0u) {
        const uint8_t reg = wr[0];
        if (!readable(reg)) {
            return VEML_MODEL_NACK;
        }
        if (wr_len == 3u) {
            if (reg != REG_CONF) {
                return VEML_MODEL_NACK; /* read-only register */
            }
            write_conf(m, now_us, (uint16_t)(wr[1] | (wr[2] << 8)));
        } else if (wr_len != 1u) {
            return VEML_MODEL_NACK;
        }
        m->pointer = reg;
    }
    if (rd_len == 0u) {
        return VEML_MODEL_OK;
    }
    const uint16_t value = read_reg(m, m->pointer);
    for (uint32_t i = 0u; i < rd_len; i++) {
        rd[i] = i == 0u ? (uint8_t)(value & 0xFFu) : i == 1u ? (uint8_t)(value >> 8) : 0xFFu;
    }
    return VEML_MODEL_OK;
}
