/* LED sequencer output stage: drives the nine PWM channels (3 LEDs × R, G, B) for one step and
 * remembers what is lit, so the scheduler knows whether the LEDs need time to settle. */
#ifndef STAC_LEDS_H
#define STAC_LEDS_H

#include <stdbool.h>
#include <stdint.h>

#include "generated/stac_messages.h"
#include "stac_hal.h"

typedef struct stac_leds {
    uint16_t lit[STAC_LEDS][STAC_COLOURS];
    bool known; /* false until the first apply: the PWM state after reset is not trusted */
} stac_leds_t;

void stac_leds_init(stac_leds_t *leds);

/* Light one step's duties (duty[led * STAC_COLOURS + colour], permille). Returns true if any output changed (the light needs to settle
 * before an integration may start), false if the step was already lit. */
bool stac_leds_apply(stac_leds_t *leds, const stac_hal_t *hal, const uint16_t *duty);

/* All LEDs dark (idle, not streaming). */
void stac_leds_off(stac_leds_t *leds, const stac_hal_t *hal);

#endif /* STAC_LEDS_H */
