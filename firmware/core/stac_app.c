#include "stac_app.h"

#include "stac_cmd.h"
#include "stac_acquisition.h"

/* Bytes read from the UART per pass: bounds the pass time under a flood of input while
 * staying far above what a 921600 baud link delivers between passes. */
#define RX_BYTES_PER_PASS 512u
#define IDLE_WAKE_US 10000u

void stac_app_init(stac_app_t *app, const stac_hal_t *hal, const stac_identity_t *id,
                   uint32_t now_us) {
    stac_state_init(app, hal, id, now_us);
    stac_acquisition_probe(app);
    stac_leds_off(&app->leds, &app->hal);
}

static void receive(stac_app_t *app) {
    uint8_t chunk[64];
    uint32_t total = 0u;
    while (total < RX_BYTES_PER_PASS) {
        const uint32_t n = app->hal.link_read(app->hal.ctx, chunk, sizeof chunk);
        if (n == 0u) {
            return;
        }
        total += n;
        for (uint32_t i = 0u; i < n && i < sizeof chunk; i++) {
            switch (stac_rx_push(&app->rx, chunk[i])) {
            case STAC_RX_FRAME: stac_cmd_handle(app, app->rx.buf, app->rx.len); break;
            case STAC_RX_OVERSIZE: app->stats.rx_errors++; break;
            default: break;
            }
        }
    }
}

void stac_app_step(stac_app_t *app, uint32_t now_us) {
    stac_state_advance(app, now_us);
    receive(app);
    stac_acquisition_run(app);
}

uint32_t stac_app_next_wake_us(const stac_app_t *app) {
    return stac_acquisition_next_wake(app, IDLE_WAKE_US);
}
