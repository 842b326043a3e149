/* Acquisition timeline on a Cortex-M4F under QEMU (-M netduinoplus2, -icount): the whole
 * firmware core (stac_app: commands, acquisition, model store, decoder) runs its superloop
 * against three VEML3328 register models (ports/native/veml_model.c: the sensor model's
 * integration timing) while the device clock is derived from the instructions QEMU executes.
 *
 * Time. SysTick counts virtual time, which -icount advances a fixed step per instruction; a
 * calibration loop converts ticks to instructions, and instructions become cycles at the CPI
 * the host passes in (tests/firmware/test_decode_timeline_qemu.py takes it from the decode
 * bench's cycle model), then microseconds at 96 MHz. Waiting is modelled as a WFI: when the
 * core has nothing to do before its next wake-up the clock jumps there (the superloop would
 * spin), and each I2C transfer costs its bytes at 400 kHz (the STM32 driver polls the bus).
 *
 * Model store: the host loads a 448 KiB region (image, commit record) at STORE_ADDR with
 * QEMU's loader, so the core boots with the model installed. Input (timeline.in): u32 CPI x
 * 1000, u32 estimates (0/1), u32 samples, u32 integration_ms. Output (timeline.out): every
 * frame the device sends as u64 device time (µs), u32 length, the frame's bytes; and
 * (timeline.boot) the u64 instructions of the boot, which validates the installed model.
 * Built by the PlatformIO env `timeline`. */
#include <stdint.h>
#include <string.h>

#include "semihost.h"
#include "stac_app.h"
#include "stac_frame.h"
#include "veml_model.h"

#define STORE_ADDR 0x08080000u
#define STORE_SIZE (448u * 1024u)
#define CPU_HZ 96u /* MHz */
#define I2C_US_PER_BYTE_X10 225u /* 9 bits at 400 kHz */

#define CALIB_ITERS 100000u

static uint32_t g_out;

static void write_out(const void *buf, uint32_t n) { sh_write(g_out, buf, n); }

/* ------------------------------------------------------------------ the modelled clock */
static uint32_t g_cpi_x1000;
static uint64_t g_ticks;        /* SysTick ticks since start, unwrapped */
static uint32_t g_last_cvr;
static uint64_t g_ticks_per_kinsn; /* calibrated: ticks per 1000 instructions */
static uint64_t g_waited_us;    /* modelled waits: WFI until the next wake-up, bus transfers */

/* Instructions executed since start. */
static uint64_t instructions(void) {
    const uint32_t cvr = SYST_CVR;
    g_ticks += (g_last_cvr - cvr) & 0xFFFFFFu;
    g_last_cvr = cvr;
    return g_ticks * 1000u / g_ticks_per_kinsn;
}

static uint64_t now_us(void) {
    return instructions() * g_cpi_x1000 / 1000u / CPU_HZ + g_waited_us;
}

static void calibrate(void) {
    const uint32_t ticks = systick_spin(CALIB_ITERS);
    g_ticks_per_kinsn = (uint64_t)ticks * 1000u / (2u * CALIB_ITERS);
    if (g_ticks_per_kinsn == 0u) g_ticks_per_kinsn = 1u;
    g_last_cvr = SYST_CVR;
}

/* ------------------------------------------------------------------ the HAL */
static veml_model_t g_sensors[3];
static uint8_t g_rx[STAC_MAX_FRAME];
static uint32_t g_rx_len, g_rx_pos;

static int32_t window_counts(void *ctx, uint8_t index, uint64_t t0_us, uint64_t t1_us,
                             uint16_t conf, uint16_t counts[VEML_MODEL_CHANNELS],
                             uint8_t *saturated) {
    (void)ctx;
    (void)t0_us;
    (void)t1_us;
    (void)conf;
    for (uint32_t c = 0u; c < VEML_MODEL_CHANNELS; c++) {
        counts[c] = (uint16_t)(1000u + 100u * index + 37u * c);
    }
    *saturated = 0u;
    return 0;
}

static int32_t hal_i2c(void *ctx, uint8_t bus, uint8_t addr7, const uint8_t *wr, uint32_t wr_len,
                       uint8_t *rd, uint32_t rd_len, uint32_t timeout_us) {
    (void)ctx;
    (void)addr7;
    (void)timeout_us;
    if (bus >= 3u) return STAC_I2C_BUS_ERROR;
    const uint32_t bytes = 1u + wr_len + (rd_len > 0u ? 1u + rd_len : 0u); /* with addresses */
    g_waited_us += bytes * I2C_US_PER_BYTE_X10 / 10u;
    const int32_t rc = veml_model_transfer(&g_sensors[bus], now_us(), wr, wr_len, rd, rd_len);
    return rc == VEML_MODEL_OK ? STAC_I2C_OK : rc == VEML_MODEL_NACK ? STAC_I2C_NACK
                                                                     : STAC_I2C_BUS_ERROR;
}

static void hal_pwm(void *ctx, uint8_t led, uint8_t colour, uint16_t duty) {
    (void)ctx;
    (void)led;
    (void)colour;
    (void)duty;
}

static uint32_t hal_write(void *ctx, const uint8_t *data, uint32_t len) {
    (void)ctx;
    const uint64_t t = now_us();
    write_out(&t, sizeof t);
    write_out(&len, sizeof len);
    write_out(data, len);
    return len;
}

static uint32_t hal_read(void *ctx, uint8_t *buf, uint32_t cap) {
    (void)ctx;
    uint32_t n = g_rx_len - g_rx_pos;
    if (n > cap) n = cap;
    memcpy(buf, g_rx + g_rx_pos, n);
    g_rx_pos += n;
    return n;
}

static uint32_t hal_clock(void *ctx) {
    (void)ctx;
    return (uint32_t)now_us();
}

static void hal_uid(void *ctx, uint8_t uid[STAC_UID_SIZE]) {
    (void)ctx;
    memset(uid, 0x3C, STAC_UID_SIZE);
}

static uint32_t hal_store_capacity(void *ctx) {
    (void)ctx;
    return STORE_SIZE;
}

static const uint8_t *hal_store_data(void *ctx) {
    (void)ctx;
    return (const uint8_t *)STORE_ADDR;
}

static int32_t hal_store_erase(void *ctx, uint32_t offset, uint32_t len) {
    (void)ctx;
    (void)offset;
    (void)len;
    return STAC_FLASH_FAILED; /* the region is QEMU's read-only flash, loaded by the host */
}

static int32_t hal_store_program(void *ctx, uint32_t offset, const uint8_t *data, uint32_t len) {
    (void)ctx;
    (void)offset;
    (void)data;
    (void)len;
    return STAC_FLASH_FAILED;
}

static stac_app_t g_app;

int main(void) {
    systick_start();
    calibrate();
    static const char in_name[] = "timeline.in", out_name[] = "timeline.out";
    const uint32_t in = sh_open(in_name, sizeof in_name - 1u, SH_OPEN_RB);
    g_out = sh_open(out_name, sizeof out_name - 1u, SH_OPEN_WB);
    if (in == SH_BAD_HANDLE || g_out == SH_BAD_HANDLE) return 1;
    uint32_t params[4];
    if (sh_read(in, params, sizeof params) != 0u) return 2;
    g_cpi_x1000 = params[0];
    const uint32_t estimates = params[1], samples = params[2];

    for (uint8_t k = 0u; k < 3u; k++) {
        veml_model_init(&g_sensors[k], k, 1u, window_counts, 0);
    }
    const stac_hal_t hal = {
        .i2c_transfer = hal_i2c,
        .pwm_set = hal_pwm,
        .link_write = hal_write,
        .link_read = hal_read,
        .clock_us = hal_clock,
        .unique_id = hal_uid,
        .store_capacity = hal_store_capacity,
        .store_data = hal_store_data,
        .store_erase = hal_store_erase,
        .store_program = hal_store_program,
    };
    stac_identity_t id;
    memset(&id, 0, sizeof id);
    memcpy(id.board, "qemu-timeline", 13);
    id.capabilities = STAC_CAPS_CORE | STAC_CAPS_MODEL;
    /* Boot, with the model store's validation of the installed model: its instructions go to
     * timeline.boot (tests/firmware/test_store_watchdog.py bounds the watchdog with them). */
    const uint64_t boot0 = instructions();
    stac_app_init(&g_app, &hal, &id, hal_clock(0));
    const uint64_t boot_insns = instructions() - boot0;
    static const char boot_name[] = "timeline.boot";
    const uint32_t boot = sh_open(boot_name, sizeof boot_name - 1u, SH_OPEN_WB);
    if (boot == SH_BAD_HANDLE) return 6;
    sh_write(boot, &boot_insns, sizeof boot_insns);
    sh_close(boot);
    if (g_app.store.present != STAC_STORE_UPLOADED) return 7; /* the region did not validate */

    /* The host's one command: stream at the given integration time, with estimates or not. */
    stac_configure_t c;
    stac_default_config(&c);
    c.integration_ms = (uint16_t)params[3];
    c.flags = (uint8_t)(STAC_CONFIG_STREAM | (estimates != 0u ? STAC_CONFIG_ESTIMATE : 0u));
    uint8_t payload[STAC_CONFIGURE_SIZE];
    const size_t plen = stac_configure_pack(&c, payload);
    g_rx_len = (uint32_t)stac_frame_encode(STAC_MSG_CONFIGURE, 1u, payload, plen, g_rx,
                                           sizeof g_rx);

    const uint64_t limit = (uint64_t)samples * params[3] * 4000u + 1000000u;
    while (g_app.stats.samples_taken < samples && now_us() < limit) {
        stac_app_step(&g_app, (uint32_t)now_us());
        const uint32_t now = (uint32_t)now_us();
        const uint32_t wake = stac_app_next_wake_us(&g_app);
        if (g_rx_pos == g_rx_len && stac_before(now, wake)) {
            g_waited_us += wake - now; /* WFI until the next thing to do */
        }
    }
    sh_close(g_out);
    return g_app.stats.samples_taken >= samples ? 0 : 5;
}
