/* On-device decoding: an interpreter for model images (spectratac.decode.export.model_image).
 *
 * A model image is the whole decoder as bytes: how live samples are assembled (LED steps,
 * context lags, moving averages, drift baseline), the feature rows, normalisation, the
 * network (linear, MLP or ResMLP with tanh-GELU and LayerNorm; float32, float16 or int8
 * weights with per-row scales), the heads and the out-of-distribution guard. The image stays
 * where it is (flash); stac_model_open only checks it and records where each array lies.
 *
 * No heap, no globals written: everything that changes lives in stac_model_state_t, which
 * the caller owns (one per session). Every loop is bounded by the compile-time limits below,
 * which stac_model_open enforces and MODEL_INFO reports.
 *
 * Drift baseline: with a rest signature in the image (flag rest) the baseline first makes sure
 * it starts from rest, exactly as decode/assemble._Baseline does: a stream that starts on a
 * pressed skin follows the skin down to its first release before the baseline adapts, and
 * every estimate until then carries EST_NO_REST. The device cannot know whether it is the
 * unit the model was trained on, so it runs the search as the host does for another or an
 * unknown unit (a skin still for HOLD samples stands in for the model's rest).
 *
 * Arithmetic: float32 throughout the network (the Python reference's runtime dtype); the
 * moving averages and the baseline are recursive sums over hundreds of samples and are kept
 * in double exactly as decode/assemble.py keeps them (float32 state drifts by more than the
 * 1e-5 relative the exports promise).
 */
#ifndef STAC_MODEL_H
#define STAC_MODEL_H

#include <stdint.h>

#include "generated/stac_vocabulary.h"

/* The image's layout (header offsets, section ids, formats, flags) and the interpreter's
 * compile-time limits (static scratch; an image beyond them is STAC_MODEL_INVALID) are generated
 * from hardware/definitions/model_image.toml, the definition the exporter writes images from.
 * The limits are sized for TrainSpec.best() (context 8, three moving averages, drift baseline:
 * 156 inputs, 189 features at one LED step) up to four LED steps with hidden width up to 256
 * (resmlp-large of the paper's 128). */
#include "generated/stac_model_image.h"

#define STAC_MODEL_MAX_BASE (STAC_MODEL_MAX_STEPS * STAC_MODEL_CHANNELS)
#define STAC_MODEL_MAX_LAYERS (2u * STAC_MODEL_MAX_BLOCKS + 2u)

/* One linear layer y = W x + b inside the image. */
typedef struct {
    const uint8_t *w;     /* n_out x n_in weights in the image's format, row-major */
    const float *scale;   /* int8: one scale per output row; NULL otherwise */
    const float *bias;    /* n_out */
    uint16_t n_in, n_out;
} stac_model_layer_t;

/* Compressed sparse rows of a feature matrix (L, P or Q). */
typedef struct {
    const uint16_t *ptr; /* rows + 1 */
    const uint16_t *idx; /* column of each non-zero */
    const float *val;
} stac_model_csr_t;

/* An opened (validated) image: dimensions and pointers into it. Read-only after open. */
typedef struct {
    const uint8_t *image;
    uint32_t size, crc, model_id;
    uint8_t weight_format, arch, steps, n_lags, n_emas, drift, uncertainty, contact_head;
    uint16_t n_in, n_base, n_feat, n_lin, n_rat, hidden, blocks, n_out, n_reg, n_classes;
    uint16_t n_dark, hist;
    uint8_t target_map[STAC_MODEL_N_TARGETS]; /* Fx..Tz -> regression index or TARGET_ABSENT */
    float saturation;      /* inputs at or above it are out of distribution; 0: none */
    float dark_counts;     /* a guarded Clear column below it is dark: out of distribution */
    double contact_force;  /* |F| above it is contact (models without a contact head) */
    double base_tau, base_gate; /* baseline time constant (samples) and no-contact gate */
    uint32_t base_stuck;        /* samples out of the gate before the baseline follows */
    const uint8_t *rest, *press; /* rest signature (flag rest): n_base f64 each; NULL without */
    double rest_score;          /* press . log(rest): the model's rest on the press axis */
    double ema_alpha[STAC_MODEL_MAX_EMAS];
    const uint16_t *lags;
    const float *center, *f_mean, *f_std;
    stac_model_csr_t lin, rat_p, rat_q;
    stac_model_layer_t layers[STAC_MODEL_MAX_LAYERS];
    uint16_t n_layers;
    const float *norms; /* resmlp: (blocks + 1) x (gain[hidden], bias[hidden]) */
    const float *y_scale, *std_mul, *t_lo, *t_hi, *in_lo, *in_hi;
    const uint16_t *dark_cols;
} stac_model_t;

/* One session's state and the scratch of one decode. Plain data the caller owns. */
typedef struct {
    float latest[STAC_MODEL_MAX_BASE]; /* newest sample of each LED step */
    uint8_t seen[STAC_MODEL_MAX_STEPS];
    float hist[STAC_MODEL_MAX_HIST][STAC_MODEL_MAX_BASE]; /* ring of assembled samples */
    uint16_t hist_len, hist_head;
    uint32_t n_assembled;
    double ema[STAC_MODEL_MAX_EMAS][STAC_MODEL_MAX_BASE];
    double base[STAC_MODEL_MAX_BASE];
    uint32_t out_of_gate;
    uint8_t ema_ready, base_ready;
    /* the search for rest (decode/assemble._Baseline; images with a rest signature) */
    double low[STAC_MODEL_MAX_BASE]; /* the lowest (least pressed) stretch seen so far */
    double low_score;                /* its press score */
    uint32_t still;                  /* samples still at the low */
    uint8_t searching, armed, on_rest, rest_seen, tare;
    /* scratch: assembled vector, features, hidden activations, all head outputs */
    float u[STAC_MODEL_MAX_INPUTS];
    float z[STAC_MODEL_MAX_FEATURES];
    float h[STAC_MODEL_MAX_HIDDEN], n[STAC_MODEL_MAX_HIDDEN], t[STAC_MODEL_MAX_HIDDEN];
    float out[STAC_MODEL_MAX_OUTPUTS]; /* the decoder's outputs in its own order */
} stac_model_state_t;

typedef struct {
    float force[STAC_FORCE_AXES];   /* Fx Fy Fz [N]; NaN if absent from the model or EST_INVALID */
    float torque[STAC_TORQUE_AXES]; /* Tx Ty Tz [N m]; likewise */
    uint8_t region;  /* 1..K, 0 without a region head or when EST_INVALID */
    float region_prob;  /* NaN without a region head */
    float contact_prob; /* NaN without a contact head */
    uint8_t flags;      /* STAC_EST_* bits */
} stac_model_output_t;

/* STAC_OK, or STAC_MODEL_INVALID: bad magic, version, size, CRC, a section out of bounds
 * or misaligned, or a dimension beyond the limits above. On error `m` is zeroed. */
uint16_t stac_model_open(stac_model_t *m, const uint8_t *image, uint32_t size);

/* The same, for a caller that has already run the CRC-32C over the image's body (every byte
 * before its trailing CRC) as part of its own pass (the model store checks the transfer CRC
 * and the image's own CRC in one pass over flash): `body_crc` is that CRC, compared here with
 * the image's trailer instead of reading the image once more. */
uint16_t stac_model_open_crc(stac_model_t *m, const uint8_t *image, uint32_t size,
                             uint32_t body_crc);

/* Start a new session: context, moving averages and baseline forgotten. */
void stac_model_reset(const stac_model_t *m, stac_model_state_t *st);

/* Make the next assembled sample the drift baseline's zero (the skin is at rest now): the
 * TARE command, as Decoder.tare() on the host. A tare asked for before a stream starts
 * survives the reset at its START (as the host's tare() before stream()). */
void stac_model_tare(stac_model_state_t *st);

/* Feed one sample (the LED step that lit it, counts[sensor][R G B C IR], SENSOR_* status).
 * Returns 1 when `out` holds an estimate, 0 (state unchanged apart from the step's latest
 * counts) until every LED step of the model has been seen since the reset. A step beyond
 * the model's steps gives 1 with EST_INVALID and leaves the state unchanged. C11 does not
 * convert uint16_t (*)[5] to const uint16_t (*)[5] implicitly (-pedantic warns): pass a
 * non-const array as (const uint16_t(*)[5])counts. */
int stac_model_push(const stac_model_t *m, stac_model_state_t *st, uint8_t led_step,
                    const uint16_t counts[STAC_SENSORS][STAC_CHANNELS],
                    const uint8_t sensor_status[STAC_SENSORS], stac_model_output_t *out);

#endif /* STAC_MODEL_H */
