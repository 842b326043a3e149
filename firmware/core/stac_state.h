/* The application's state and the services every layer of the core shares.
 *
 * One stac_app_t instance holds all state (no globals, no heap), so a host can run several
 * simulated devices in one process. This file is the bottom of the application's layers
 * (firmware/README.md): stac_acquisition and stac_cmd work on the instance through it, and stac_app
 * (the superloop pass) drives both; nothing here calls up into them. */
#ifndef STAC_STATE_H
#define STAC_STATE_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "generated/stac_messages.h"
#include "stac_frame.h"
#include "stac_hal.h"
#include "stac_leds.h"
#include "stac_model_store.h"

#define STAC_FW_VERSION_MAJOR 0u
#define STAC_FW_VERSION_MINOR 1u
#define STAC_FW_VERSION_PATCH 0u

#define STAC_TEXT_SIZE 16u

/* Capabilities every build of this core implements. */
#define STAC_CAPS_CORE \
    (STAC_CAP_LED_SEQUENCE | STAC_CAP_TIME_SYNC | STAC_CAP_STATUS | STAC_CAP_LOG | \
     STAC_CAP_IR_CHANNEL)

/* Capabilities of a build whose HAL has a model store: on-device decoding and uploads. */
#define STAC_CAPS_MODEL (STAC_CAP_ESTIMATE | STAC_CAP_MODEL_UPLOAD)

/* What the port found at boot (STATUS, protocol 1.4): why the device reset, the fault record
 * that survived it, and the brown-out level of the option bytes. */
typedef struct stac_boot {
    uint8_t reset_cause;     /* STAC_RESET_* bits */
    uint8_t abnormal_resets; /* faults, watchdog and brown-out resets in a row */
    uint8_t safe_mode;       /* 1: boot without the model store (too many abnormal resets) */
    uint8_t bor_level;       /* 0 off .. 3; MODEL_BEGIN needs STAC_BOR_LEVEL_FOR_FLASH */
    uint32_t fault_pc, fault_lr, fault_xpsr;
    uint32_t fault_cfsr, fault_hfsr, fault_mmfar, fault_bfar;
    const char *note; /* NULL, or a degraded start-up the boot LOG adds (e.g. the clock) */
} stac_boot_t;

/* Brown-out level that holds the supply at >= 2.7 V, which 32-bit flash writes need. */
#define STAC_BOR_LEVEL_FOR_FLASH 3u
/* Abnormal resets in a row after which the device boots without its model store. */
#define STAC_SAFE_MODE_AFTER 3u

/* What INFO reports about the board; supplied by the port. */
typedef struct stac_identity {
    char board[STAC_TEXT_SIZE];    /* NUL-padded, e.g. "blackpill-f411" */
    char build_id[STAC_TEXT_SIZE]; /* NUL-padded, e.g. git describe */
    uint32_t capabilities;         /* STAC_CAP_* bits */
    uint32_t baud;                 /* UART rate, 0 when not a UART */
    stac_boot_t boot;              /* reset cause, fault record, brown-out level */
} stac_identity_t;

typedef struct stac_stats {
    uint32_t samples_taken;
    uint32_t frames_sent;
    uint32_t frames_dropped;
    uint32_t bus_errors[STAC_SENSORS];
    uint32_t saturations[STAC_SENSORS];
    uint32_t rx_frames;
    uint32_t rx_errors;
    uint32_t command_errors;
    /* CPU cycles (HAL cycle counter; all 0 without one): one sample's acquisition work and
     * one decode, the last and the largest. */
    uint32_t acq_cycles_last, acq_cycles_max;
    uint32_t decode_cycles_last, decode_cycles_max;
    /* Flash erase of one MODEL_BEGIN or MODEL_CLEAR (µs), and per sensor the TRIG write to
     * data-ready time (µs), the last and the largest (protocol 1.4). */
    uint32_t erase_us_last, erase_us_max;
    uint32_t trig_latency_us_last[STAC_SENSORS], trig_latency_us_max[STAC_SENSORS];
} stac_stats_t;

/* Acquisition state: one cycle = light a step, let it settle, integrate, read, send. */
typedef enum stac_acq_state {
    STAC_ACQ_IDLE = 0,  /* between cycles, or not streaming */
    STAC_ACQ_SETTLE,    /* LEDs set, waiting settle time before the trigger */
    STAC_ACQ_INTEGRATE  /* sensors triggered, waiting for them to finish */
} stac_acq_state_t;

typedef struct stac_acq {
    uint8_t state;           /* stac_acq_state_t */
    uint8_t step;            /* LED step of the current / next cycle */
    uint8_t pending;         /* sensors whose measurement has not finished yet */
    uint8_t done;            /* sensors that finished this window */
    uint8_t fault;           /* sensors whose transfer failed this window */
    bool busy;               /* a triggered measurement may still be running (after STOP) */
    uint32_t settle_until;   /* SETTLE: trigger time */
    uint32_t t_start;        /* INTEGRATE: trigger time */
    uint32_t poll_at;        /* INTEGRATE: next completion poll */
    uint32_t deadline;       /* INTEGRATE: give up waiting (sensor reported stale) */
    uint16_t last_counts[STAC_SENSORS][STAC_CHANNELS]; /* last good reading per sensor */
    uint32_t cycles;         /* CPU cycles spent on the window in flight so far */
    /* The finished sample waiting for the model: decoded after the next integration has been
     * triggered, so decoding runs while the sensors integrate instead of delaying them. */
    bool decode_pending;
    stac_sample_t decode_sample;
    uint32_t decodes; /* model steps run since boot (never reset: a port may model their time) */
} stac_acq_t;

typedef struct stac_app {
    stac_hal_t hal;
    stac_identity_t id;
    uint8_t uid[STAC_UID_SIZE];

    uint32_t now;       /* time of the current pass (µs) */
    uint64_t uptime_us; /* accumulated from pass to pass, so it outlives the 32-bit wrap */

    stac_configure_t cfg;     /* configuration in force */
    uint16_t cfg_id;
    stac_configure_t pending; /* accepted, applied at the next integration start */
    bool has_pending;
    uint16_t latest_id;       /* id of the newest accepted configuration */

    bool streaming;
    uint32_t sample_seq;
    uint8_t present; /* bit k: sensor k answered its ID probe */
    uint8_t lost;    /* bit k: sensor k's last transfer failed (logged once) */

    stac_leds_t leds;
    stac_acq_t acq;
    stac_stats_t stats;
    stac_rx_t rx;
    uint16_t tx_seq;

    stac_model_store_t store; /* the decoder in use and the upload in progress */
    stac_model_state_t est;   /* its session: context, averages, baseline, scratch */

    bool boot_logged; /* the boot LOG (reset cause, fault record) went out with the first answer */
    uint8_t log_tokens; /* LOG rate limit: a burst of a few, then one per second */
    uint32_t log_refill_at;

    uint8_t frame[STAC_MAX_FRAME]; /* encode scratch */
} stac_app_t;

/* Fresh state: default configuration in force and pending, LEDs and receiver reset, full LOG
 * budget, not streaming. The HAL is stored and asked for the unique id, and the model store is
 * validated (stac_store_boot) unless the port booted in safe mode; nothing else runs. */
void stac_state_init(stac_app_t *app, const stac_hal_t *hal, const stac_identity_t *id,
                     uint32_t now_us);

/* Start of a pass at now_us: accumulate uptime across the 32-bit wrap, refill the LOG budget. */
void stac_state_advance(stac_app_t *app, uint32_t now_us);

/* Frame and hand one message to the UART; counts it as sent or dropped. */
bool stac_app_send(stac_app_t *app, uint8_t type, const uint8_t *payload, size_t len);

/* Send a LOG message unless the rate limit says the host has heard enough for now. */
void stac_app_log(stac_app_t *app, uint8_t level, const char *text);

/* Fresh clock reading (the HAL's) for timestamps taken within a pass. */
uint32_t stac_app_clock(const stac_app_t *app);

/* The HAL's cycle counter, or 0 when the port has none. */
uint32_t stac_app_cycles(const stac_app_t *app);

/* True when the configuration in force asks for estimates and a model is there to make them. */
bool stac_state_estimating(const stac_app_t *app);

/* Start a new decoding session (START, a configuration applied, another model in use). */
void stac_state_estimator_reset(stac_app_t *app);

/* Default configuration at boot: 50 ms, ×1, DG ×1, high sensitivity, one step at 500 ‰,
 * settle 1000 µs, not streaming. */
void stac_default_config(stac_configure_t *cfg);

/* Elapsed µs between two readings of the HAL's cycle counter (or, without one, its clock). */
uint32_t stac_app_elapsed_us(const stac_app_t *app, uint32_t cycles0, uint32_t clock0);

/* Send the boot LOG once (reset cause, fault record, safe mode, brown-out level), if the boot
 * is worth a word: anything but a clean power-on or pin reset with brown-out level 3; the
 * port's note, if any, follows as a second line. */
void stac_app_boot_log(stac_app_t *app);

/* Wrap-safe "a is before b" for 32-bit µs times less than 2^31 apart. */
static inline bool stac_before(uint32_t a, uint32_t b) {
    return (int32_t)(a - b) < 0;
}

#endif /* STAC_STATE_H */
