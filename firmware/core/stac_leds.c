#include "stac_leds.h"

void stac_leds_init(stac_leds_t *leds) {
    for (uint32_t l = 0u; l < STAC_LEDS; l++) {
        for (uint32_t c = 0u; c < STAC_COLOURS; c++) {
            leds->lit[l][c] = 0u;
        }
    }
    leds->known = false;
}

bool stac_leds_apply(stac_leds_t *leds, const stac_hal_t *hal, const uint16_t *duty) {
    bool changed = !leds->known;
    for (uint32_t l = 0u; l < STAC_LEDS; l++) {
        for (uint32_t c = 0u; c < STAC_COLOURS; c++) {
            const uint16_t want = duty[l * STAC_COLOURS + c];
            const uint16_t d = want > STAC_DUTY_FULL_SCALE ? (uint16_t)STAC_DUTY_FULL_SCALE : want;
            if (!leds->known || leds->lit[l][c] != d) {
                hal->pwm_set(hal->ctx, (uint8_t)l, (uint8_t)c, d);
                leds->lit[l][c] = d;
                changed = true;
            }
        }
    }
    leds->known = true;
    return changed;
}

void stac_leds_off(stac_leds_t *leds, const stac_hal_t *hal) {
    static const uint16_t k_dark[STAC_LEDS * STAC_COLOURS] = {0u};
    (void)stac_leds_apply(leds, hal, k_dark);
}
