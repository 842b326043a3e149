/* The firmware application, top of the core's layers: a port fills a stac_hal_t, calls
 * stac_app_init once and then stac_app_step(now_us) from its superloop. Each pass hands
 * received frames to the command layer (stac_cmd) and advances acquisition (stac_acquisition); the
 * instance they share is stac_state.h's stac_app_t. */
#ifndef STAC_APP_H
#define STAC_APP_H

#include <stdint.h>

#include "stac_state.h"

/* Prepare an instance: default configuration, sensors probed, not streaming, silent. */
void stac_app_init(stac_app_t *app, const stac_hal_t *hal, const stac_identity_t *id,
                   uint32_t now_us);

/* One superloop pass: read received bytes and answer commands, advance acquisition. Takes a
 * bounded time; call it again no later than stac_app_next_wake_us() or when bytes arrive. */
void stac_app_step(stac_app_t *app, uint32_t now_us);

/* The latest time at which the next pass should run (earlier is always allowed). */
uint32_t stac_app_next_wake_us(const stac_app_t *app);

#endif /* STAC_APP_H */
