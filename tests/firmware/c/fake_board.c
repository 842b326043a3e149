#include "fake_board.h"

#include <string.h>

#include "veml3328.h"

static uint32_t it_us_of(uint16_t conf) {
    static const uint32_t k_it_ms[VEML3328_CONF_IT_COUNT] = VEML3328_CONF_IT_VALUES;
    return k_it_ms[(conf & VEML3328_CONF_IT_MASK) >> VEML3328_CONF_IT_SHIFT] * 1000u;
}

static uint32_t led_sum(const fake_board_t *b) {
    uint32_t s = 0u;
    for (int l = 0; l < 3; l++) {
        for (int c = 0; c < 3; c++) {
            s += b->duty[l][c];
        }
    }
    return s;
}

/* Let a running measurement finish if its time has come. */
static void settle(fake_board_t *b, fake_sensor_t *s, uint8_t bus) {
    if (!s->measuring || s->mode == FAKE_NEVER_DONE) {
        return;
    }
    const uint32_t dur = s->it_us + (uint32_t)((uint64_t)s->it_us * s->slow_ppm / 1000000u);
    if ((int32_t)(b->now - (s->trig_at + dur)) < 0) {
        return;
    }
    s->measuring = false;
    s->fresh = true;
    s->conf &= (uint16_t)~VEML3328_CONF_TRIG;
    for (int ch = 0; ch < 5; ch++) {
        const uint32_t v = s->base[ch] + s->led_sum_at_trigger;
        s->data[ch] = s->saturate ? 0xFFFFu : (uint16_t)(v > 0xFFFEu ? 0xFFFEu : v);
    }
    if (b->n_win < FAKE_MAX_WINDOWS) {
        b->win[b->n_win].start = s->trig_at;
        b->win[b->n_win].end = s->trig_at + dur;
        b->win[b->n_win].bus = bus;
        b->n_win++;
    }
}

static int32_t fake_i2c(void *ctx, uint8_t bus, uint8_t addr7, const uint8_t *wr, uint32_t wr_len,
                        uint8_t *rd, uint32_t rd_len, uint32_t timeout_us) {
    fake_board_t *b = (fake_board_t *)ctx;
    if (bus > 2u || addr7 != VEML3328_ADDR) {
        return STAC_I2C_NACK;
    }
    fake_sensor_t *s = &b->s[bus];
    s->transfers++;
    int mode = s->mode;
    if (s->fail_next > 0u) {
        s->fail_next--;
        mode = s->fail_mode;
    }
    switch (mode) {
    case FAKE_ABSENT: return STAC_I2C_NACK;
    case FAKE_BUS_ERROR: return STAC_I2C_BUS_ERROR;
    case FAKE_STALL:
        b->now += timeout_us; /* the port waited out its bound */
        return STAC_I2C_TIMEOUT;
    default: break;
    }
    b->now += b->transfer_cost_us;
    settle(b, s, bus);
    if (wr_len == 0u) {
        return STAC_I2C_BUS_ERROR;
    }
    const uint8_t reg = wr[0];
    if (wr_len == 3u && rd_len == 0u) {
        const uint16_t v = (uint16_t)(wr[1] | (wr[2] << 8));
        if (reg == VEML3328_REG_CONF) {
            s->conf = v;
            const bool running = (v & VEML3328_CONF_SD) == 0u;
            if (running && (v & VEML3328_CONF_AF) && (v & VEML3328_CONF_TRIG)) {
                s->measuring = true;
                s->trig_at = b->now;
                s->it_us = it_us_of(v);
                s->led_sum_at_trigger = led_sum(b);
                s->triggers++;
            }
        }
        return STAC_I2C_OK;
    }
    if (wr_len == 1u && rd_len == 2u) {
        uint16_t v = 0u;
        switch (reg) {
        case VEML3328_REG_CONF:
            v = s->conf;
            if (s->fresh) {
                s->fresh = false;
                b->done_pass = b->pass;
            }
            break;
        case VEML3328_REG_ID: v = mode == FAKE_WRONG_ID ? 0x0035u : 0x0128u; break;
        case VEML3328_REG_R: v = s->data[0]; break;
        case VEML3328_REG_G: v = s->data[1]; break;
        case VEML3328_REG_B: v = s->data[2]; break;
        case VEML3328_REG_C: v = s->data[3]; break;
        case VEML3328_REG_IR: v = s->data[4]; break;
        default: v = 0u; break;
        }
        rd[0] = (uint8_t)v;
        rd[1] = (uint8_t)(v >> 8);
        return STAC_I2C_OK;
    }
    return STAC_I2C_BUS_ERROR;
}

static void fake_pwm(void *ctx, uint8_t led, uint8_t colour, uint16_t duty) {
    fake_board_t *b = (fake_board_t *)ctx;
    b->duty[led][colour] = duty;
    if (b->n_pwm < FAKE_MAX_PWM) {
        fake_pwm_event_t *e = &b->pwm[b->n_pwm++];
        e->t = b->now;
        e->led = led;
        e->colour = colour;
        e->duty = duty;
    }
}

static uint32_t fake_write(void *ctx, const uint8_t *data, uint32_t len) {
    fake_board_t *b = (fake_board_t *)ctx;
    if (b->tx_full || b->tx_len + len > FAKE_TX_CAP) {
        return 0u;
    }
    memcpy(b->tx + b->tx_len, data, len);
    b->tx_len += len;
    if (b->tx_frames < 1024u) {
        b->tx_pass[b->tx_frames] = b->pass;
        b->tx_done_pass[b->tx_frames] = b->done_pass;
        b->tx_triggers[b->tx_frames] = b->s[0].triggers;
    }
    b->tx_frames++;
    return len;
}

static void fake_watchdog(void *ctx) {
    ((fake_board_t *)ctx)->watchdog_refreshes++;
}

/* A cycle counter that runs FAKE_CYCLES_PER_READ cycles between two reads. */
static uint32_t fake_cycles(void *ctx) {
    fake_board_t *b = (fake_board_t *)ctx;
    b->cycle_count += FAKE_CYCLES_PER_READ;
    return b->cycle_count;
}

static uint32_t fake_read(void *ctx, uint8_t *buf, uint32_t cap) {
    fake_board_t *b = (fake_board_t *)ctx;
    size_t n = b->rx_len - b->rx_pos;
    if (n > cap) {
        n = cap;
    }
    memcpy(buf, b->rx + b->rx_pos, n);
    b->rx_pos += n;
    if (b->rx_pos == b->rx_len) {
        b->rx_pos = b->rx_len = 0u;
    }
    return (uint32_t)n;
}

static uint32_t fake_clock(void *ctx) {
    return ((const fake_board_t *)ctx)->now;
}

static void fake_uid(void *ctx, uint8_t uid[STAC_UID_SIZE]) {
    (void)ctx;
    for (uint8_t i = 0u; i < STAC_UID_SIZE; i++) {
        uid[i] = (uint8_t)(0xA0u + i);
    }
}

static uint32_t fake_store_capacity(void *ctx) {
    (void)ctx;
    return FAKE_FLASH_SIZE;
}

static const uint8_t *fake_store_data(void *ctx) {
    return ((const fake_board_t *)ctx)->flash;
}

/* Counts an operation; true when it is the one made to fail. */
static bool fake_flash_fails(fake_board_t *b) {
    const uint32_t op = b->flash_erases + b->flash_programs;
    return b->flash_fail_at != 0u && op >= b->flash_fail_at;
}

const uint32_t fake_flash_sector_start[FAKE_FLASH_SECTORS + 1u] = {0u, 4096u, 8192u, 16384u,
                                                                    FAKE_FLASH_SIZE};

static bool fake_range_ok(uint32_t offset, uint32_t len) {
    return offset % STAC_FLASH_WORD == 0u && len % STAC_FLASH_WORD == 0u &&
           offset <= FAKE_FLASH_SIZE && len <= FAKE_FLASH_SIZE - offset;
}

/* Erases every sector the range touches, whole. */
static int32_t fake_store_erase(void *ctx, uint32_t offset, uint32_t len) {
    fake_board_t *b = (fake_board_t *)ctx;
    if (!fake_range_ok(offset, len)) {
        return STAC_FLASH_BAD_ARG;
    }
    b->flash_erases++;
    if (b->flash_dead || fake_flash_fails(b)) {
        return STAC_FLASH_FAILED;
    }
    for (uint32_t k = 0u; k < FAKE_FLASH_SECTORS; k++) {
        const uint32_t lo = fake_flash_sector_start[k], hi = fake_flash_sector_start[k + 1u];
        if (len > 0u && offset < hi && offset + len > lo) {
            memset(b->flash + lo, 0xFF, hi - lo);
            b->sector_erases[k]++;
            /* The core stalls through the erase: its cycle counter and clock run on. */
            b->cycle_count += b->erase_us_per_sector * (FAKE_CYCLE_HZ / 1000000u);
            b->now += b->erase_us_per_sector;
        }
    }
    return STAC_FLASH_OK;
}

static int32_t fake_store_program(void *ctx, uint32_t offset, const uint8_t *data, uint32_t len) {
    fake_board_t *b = (fake_board_t *)ctx;
    if (!fake_range_ok(offset, len)) {
        return STAC_FLASH_BAD_ARG;
    }
    b->flash_programs++;
    if (b->flash_dead) {
        return STAC_FLASH_FAILED;
    }
    const bool fail = fake_flash_fails(b);
    int32_t rc = fail ? STAC_FLASH_FAILED : STAC_FLASH_OK;
    for (uint32_t w = 0u; w < len / STAC_FLASH_WORD; w++) {
        if (fail && w >= len / STAC_FLASH_WORD / 2u) {
            break; /* a failed write gets half-way */
        }
        if (b->flash_power_cut) {
            if (b->flash_cut_words == 0u) {
                b->flash_dead = true;
                return STAC_FLASH_FAILED;
            }
            b->flash_cut_words--;
        }
        for (uint32_t i = w * STAC_FLASH_WORD; i < (w + 1u) * STAC_FLASH_WORD; i++) {
            b->flash[offset + i] &= data[i];
            if (b->flash[offset + i] != data[i]) {
                rc = STAC_FLASH_FAILED;
            }
        }
    }
    return rc;
}

static void fake_enter_bootloader(void *ctx) {
    fake_board_t *b = (fake_board_t *)ctx;
    b->bootloader_calls++;
    b->tx_len_at_hook = b->tx_len;
}

static void fake_debug_fault(void *ctx, uint8_t kind) {
    fake_board_t *b = (fake_board_t *)ctx;
    b->fault_calls++;
    b->fault_kind = kind;
    b->tx_len_at_hook = b->tx_len;
}

void fake_test_image(fake_board_t *b) {
    b->hal.enter_bootloader = fake_enter_bootloader;
    b->hal.debug_fault = fake_debug_fault;
}

void fake_init(fake_board_t *b) {
    memset(b, 0, sizeof *b);
    b->now = 1000u;
    b->transfer_cost_us = 100u;
    for (int k = 0; k < 3; k++) {
        b->s[k].conf = VEML3328_CONF_SD; /* power-on state: shut down */
        for (int ch = 0; ch < 5; ch++) {
            b->s[k].base[ch] = (uint16_t)(1000 * (k + 1) + 100 * ch);
        }
    }
    b->hal.ctx = b;
    b->hal.i2c_transfer = fake_i2c;
    b->hal.pwm_set = fake_pwm;
    b->hal.link_write = fake_write;
    b->hal.link_read = fake_read;
    b->hal.clock_us = fake_clock;
    b->hal.unique_id = fake_uid;
    b->hal.store_capacity = fake_store_capacity;
    b->hal.store_data = fake_store_data;
    b->hal.store_erase = fake_store_erase;
    b->hal.store_program = fake_store_program;
    b->hal.watchdog_refresh = fake_watchdog;
    b->hal.cycles = fake_cycles;
    b->hal.cycle_hz = FAKE_CYCLE_HZ;
    memset(b->flash, 0xFF, sizeof b->flash);
    b->boot.reset_cause = STAC_RESET_POWER | STAC_RESET_PIN;
    b->boot.bor_level = STAC_BOR_LEVEL_FOR_FLASH; /* a provisioned board */
}

void fake_boot(fake_board_t *b, stac_app_t *app) {
    stac_identity_t id;
    memset(&id, 0, sizeof id);
    memcpy(id.board, "fake-board", 10);
    memcpy(id.build_id, "test", 4);
    id.capabilities = STAC_CAPS_CORE | STAC_CAPS_MODEL;
    id.baud = 921600u;
    id.boot = b->boot;
    stac_app_init(app, &b->hal, &id, b->now);
}

void fake_run_until(fake_board_t *b, stac_app_t *app, uint32_t until, uint32_t tick_us) {
    while ((int32_t)(b->now - until) < 0) {
        b->pass++;
        stac_app_step(app, b->now);
        b->now += tick_us;
    }
    b->pass++;
    stac_app_step(app, b->now);
}

void fake_send_raw(fake_board_t *b, const uint8_t *bytes, size_t len) {
    if (b->rx_len + len <= FAKE_RX_CAP) {
        memcpy(b->rx + b->rx_len, bytes, len);
        b->rx_len += len;
    }
}

void fake_send(fake_board_t *b, uint8_t type, uint16_t seq, const uint8_t *payload, size_t len) {
    uint8_t wire[STAC_MAX_FRAME];
    const size_t n = stac_frame_encode(type, seq, payload, len, wire, sizeof wire);
    fake_send_raw(b, wire, n);
}

int fake_frames(const fake_board_t *b, fake_frame_t *out, size_t cap) {
    size_t start = 0u;
    int n = 0;
    for (size_t i = 0u; i < b->tx_len; i++) {
        if (b->tx[i] != 0u) {
            continue;
        }
        uint8_t raw[STAC_MAX_DECODED];
        const uint8_t *payload = NULL;
        size_t plen = 0u;
        stac_frame_header_t h;
        if (stac_frame_decode(b->tx + start, i - start, raw, &h, &payload, &plen) !=
            STAC_FRAME_OK) {
            return -1;
        }
        if ((size_t)n < cap) {
            out[n].h = h;
            memcpy(out[n].payload, payload, plen);
            out[n].len = plen;
        }
        n++;
        start = i + 1u;
    }
    return n;
}

const fake_frame_t *fake_last(const fake_frame_t *f, int n, uint8_t type) {
    for (int i = n - 1; i >= 0; i--) {
        if (f[i].h.type == type) {
            return &f[i];
        }
    }
    return NULL;
}

int fake_count(const fake_frame_t *f, int n, uint8_t type) {
    int c = 0;
    for (int i = 0; i < n; i++) {
        c += f[i].h.type == type;
    }
    return c;
}

void fake_clear_tx(fake_board_t *b) {
    b->tx_len = 0u;
    b->tx_frames = 0u;
}
