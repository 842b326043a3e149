/* Acquisition scheduler: runs the three sensors in parallel through the LED sequence.
 *
 * One cycle per LED step: light the step (waiting led_settle_us only if the light changed),
 * trigger all sensors together in active-force mode, poll until each has cleared TRIG (or a
 * deadline passes), read them and send the SAMPLE in the same pass. The time from each TRIG
 * write to the poll that finds it clear is kept per sensor (stats.trig_latency_us_*); a sensor
 * that leaves TRIG set is read at the deadline instead (stats.trig_stuck). With a model in use the
 * sample is decoded after the next integration has been triggered, in the same pass (after the
 * LED settle when the light changes), so decoding overlaps the sensors' integration instead of
 * delaying it. The LEDs change only between a read and the next trigger, so no integration
 * straddles an LED change.
 * With one step nothing changes between cycles, so a 50 ms integration gives ~20 samples/s;
 * with N steps each step is sampled ~20/N times per second (plus settle time per cycle). */
#ifndef STAC_ACQUISITION_H
#define STAC_ACQUISITION_H

#include <stdint.h>

#include "stac_state.h"

/* How often a running integration is polled for completion once it is due. */
#define STAC_POLL_INTERVAL_US 250u
/* Extra wait beyond the nominal integration time before a sensor is reported stale: the
 * sensor's own oscillator sets the real time, so allow a quarter plus a fixed margin. */
#define STAC_STALE_MARGIN_US(it_us) ((it_us) / 4u + 2000u)

/* Probe the sensors (ID check) and power them up in active force mode. */
void stac_acquisition_probe(stac_app_t *app);

/* Begin streaming (sample_seq restarts at 0); idempotent while streaming. */
void stac_acquisition_start(stac_app_t *app);

/* Stop streaming: the integration in flight is abandoned, no SAMPLE follows, LEDs go dark. */
void stac_acquisition_stop(stac_app_t *app);

/* Advance the state machine as far as the time allows. */
void stac_acquisition_run(stac_app_t *app);

/* Next time the scheduler needs a pass, or now + idle_us when it waits for nothing. */
uint32_t stac_acquisition_next_wake(const stac_app_t *app, uint32_t idle_us);

#endif /* STAC_ACQUISITION_H */
