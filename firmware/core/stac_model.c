/* Interpreter of model images: see stac_model.h. Mirrors, step by step, what the Python
 * reference computes (decode/assemble.py, feature_matrices.py, networks.py, heads.py,
 * guard.py, decoder.py): tests feed whole sessions through both and compare sample by
 * sample. */
#include "stac_model.h"

#include <math.h>
#include <string.h>

#include "generated/stac_messages.h"
#include "generated/stac_vocabulary.h"
#include "stac_crc32c.h"

#define FEATURE_EPS 1e-5f  /* paper_features.EPS: ratio denominators stay positive */
#define LN_EPS 1e-5f       /* networks.LN_EPS */
#define GELU_K 0.7978845608028654f
#define STATUS_BAD 0x0Fu   /* guard.STATUS_BAD: saturated, bus fault, stale, absent */
/* The search for rest (decode/assemble.py: JOIN, DROP, STILL, HOLD; a test compares them), in
 * press-score units (log counts along the press direction). */
#define REST_JOIN 0.06 /* a first sample this far above the model's rest is pressed */
#define REST_DROP 0.04 /* a fall (or rise) of the score this large: contact ending (starting) */
#define REST_STILL 2u  /* samples still after coming down that make the low rest */
#define REST_HOLD 20u  /* samples still, never having come down: this skin stands in */
#define PER_SENSOR STAC_DECODED_CHANNELS /* of the wire's R G B C IR, the decoder uses R G B C */
_Static_assert(STAC_MODEL_CHANNELS == STAC_SENSORS * PER_SENSOR, "a step: every sensor's R G B C");
_Static_assert(STAC_MODEL_N_TARGETS == STAC_FT_AXES, "the image maps every F/T axis of the vocabulary");

static uint16_t rd16(const uint8_t *p) { return (uint16_t)(p[0] | (p[1] << 8)); }

static uint32_t rd32(const uint8_t *p) {
    return (uint32_t)p[0] | ((uint32_t)p[1] << 8) | ((uint32_t)p[2] << 16) |
           ((uint32_t)p[3] << 24);
}

static float rdf32(const uint8_t *p) {
    uint32_t bits = rd32(p);
    float f;
    memcpy(&f, &bits, sizeof f);
    return f;
}

static double rdf64(const uint8_t *p) {
    uint64_t bits = (uint64_t)rd32(p) | ((uint64_t)rd32(p + 4) << 32);
    double d;
    memcpy(&d, &bits, sizeof d);
    return d;
}

/* ------------------------------------------------------------------ open */

typedef struct {
    const uint8_t *image;
    uint32_t size, table_end;
    int ok;
} reader_t;

/* Pointer to section `id` if it holds exactly `bytes` bytes, lies inside the image (before
 * the CRC) and is 4-byte aligned; NULL (and the reader marked bad) otherwise. An empty
 * section gives a valid pointer that must not be read. */
static const uint8_t *section(reader_t *r, unsigned id, uint32_t bytes) {
    const uint8_t *e = r->image + STAC_MODEL_HEADER_SIZE + STAC_MODEL_ENTRY_SIZE * id;
    uint32_t off = rd32(e), len = rd32(e + 4);
    const uint32_t end = r->size - STAC_MODEL_CRC_SIZE;
    if (len != bytes || off < r->table_end || (off % STAC_MODEL_ALIGN) != 0u || off > end ||
        len > end - off) {
        r->ok = 0;
        return r->image;
    }
    return r->image + off;
}

static int csr_ok(const stac_model_csr_t *c, uint16_t rows, uint32_t nnz, uint16_t n_cols) {
    if (c->ptr[0] != 0u || c->ptr[rows] != nnz) return 0;
    for (uint32_t r = 0; r < rows; ++r)
        if (c->ptr[r + 1u] < c->ptr[r]) return 0;
    for (uint32_t k = 0; k < nnz; ++k)
        if (c->idx[k] >= n_cols) return 0;
    return 1;
}

/* Reads one CSR matrix of `rows` rows; the non-zero count comes from the index section's
 * length, which the pointer section then has to agree with. */
static void open_csr(reader_t *r, unsigned id, uint16_t rows, uint16_t n_cols,
                     stac_model_csr_t *c) {
    const uint8_t *e = r->image + STAC_MODEL_HEADER_SIZE + STAC_MODEL_ENTRY_SIZE * (id + 1u);
    uint32_t nnz = rd32(e + 4) / 2u;
    c->ptr = (const uint16_t *)(const void *)section(r, id, 2u * ((uint32_t)rows + 1u));
    c->idx = (const uint16_t *)(const void *)section(r, id + 1u, 2u * nnz);
    c->val = (const float *)(const void *)section(r, id + 2u, 4u * nnz);
    if (r->ok && !csr_ok(c, rows, nnz, n_cols)) r->ok = 0;
}

static uint16_t fail(stac_model_t *m) {
    memset(m, 0, sizeof *m);
    return STAC_MODEL_INVALID;
}

static int all_finite(const float *a, uint32_t n) {
    for (uint32_t i = 0; i < n; ++i)
        if (!isfinite(a[i])) return 0;
    return 1;
}

uint16_t stac_model_open(stac_model_t *m, const uint8_t *image, uint32_t size) {
    const uint32_t table_end =
        STAC_MODEL_HEADER_SIZE + STAC_MODEL_ENTRY_SIZE * (uint32_t)STAC_MODEL_N_SECTIONS;
    if (image == NULL || size < table_end + STAC_MODEL_CRC_SIZE) return fail(m);
    return stac_model_open_crc(m, image, size, stac_crc32c(image, size - STAC_MODEL_CRC_SIZE));
}

uint16_t stac_model_open_crc(stac_model_t *m, const uint8_t *image, uint32_t size,
                             uint32_t body_crc) {
    memset(m, 0, sizeof *m);
    const uint32_t table_end =
        STAC_MODEL_HEADER_SIZE + STAC_MODEL_ENTRY_SIZE * (uint32_t)STAC_MODEL_N_SECTIONS;
    if (image == NULL || ((uintptr_t)image & 3u) != 0u || size < table_end + STAC_MODEL_CRC_SIZE)
        return fail(m);
    if (rd32(image + STAC_MODEL_OFF_MAGIC) != STAC_MODEL_MAGIC ||
        rd16(image + STAC_MODEL_OFF_VERSION) != STAC_MODEL_VERSION ||
        rd16(image + STAC_MODEL_OFF_HEADER_SIZE) != STAC_MODEL_HEADER_SIZE ||
        rd32(image + STAC_MODEL_OFF_SIZE) != size ||
        rd16(image + STAC_MODEL_OFF_N_SECTIONS) != STAC_MODEL_N_SECTIONS)
        return fail(m);
    const uint32_t crc = rd32(image + size - STAC_MODEL_CRC_SIZE);
    if (body_crc != crc) return fail(m);

    const uint8_t flags = image[STAC_MODEL_OFF_FLAGS];
    m->image = image;
    m->size = size;
    m->crc = crc;
    m->model_id = rd32(image + STAC_MODEL_OFF_MODEL_ID);
    m->weight_format = image[STAC_MODEL_OFF_WEIGHT_FORMAT];
    m->arch = image[STAC_MODEL_OFF_ARCH];
    m->steps = image[STAC_MODEL_OFF_STEPS];
    m->n_lags = image[STAC_MODEL_OFF_N_LAGS];
    m->n_emas = image[STAC_MODEL_OFF_N_EMAS];
    m->drift = image[STAC_MODEL_OFF_DRIFT];
    m->uncertainty = (uint8_t)((flags & STAC_MODEL_FLAG_UNCERTAINTY) != 0u);
    m->contact_head = (uint8_t)((flags & STAC_MODEL_FLAG_CONTACT) != 0u);
    m->n_in = rd16(image + STAC_MODEL_OFF_N_INPUTS);
    m->n_feat = rd16(image + STAC_MODEL_OFF_N_FEATURES);
    m->n_lin = rd16(image + STAC_MODEL_OFF_N_LINEAR);
    m->n_rat = rd16(image + STAC_MODEL_OFF_N_RATIO);
    m->hidden = rd16(image + STAC_MODEL_OFF_HIDDEN);
    m->blocks = rd16(image + STAC_MODEL_OFF_BLOCKS);
    m->n_out = rd16(image + STAC_MODEL_OFF_N_OUTPUTS);
    m->n_reg = rd16(image + STAC_MODEL_OFF_N_REGRESSION);
    m->n_classes = rd16(image + STAC_MODEL_OFF_N_CLASSES);
    m->n_dark = rd16(image + STAC_MODEL_OFF_N_DARK);
    memcpy(m->target_map, image + STAC_MODEL_OFF_TARGET_MAP, STAC_MODEL_N_TARGETS);
    m->saturation = rdf32(image + STAC_MODEL_OFF_SATURATION);
    m->dark_counts = rdf32(image + STAC_MODEL_OFF_DARK_COUNTS);
    m->base_tau = rdf64(image + STAC_MODEL_OFF_BASE_TAU);
    m->base_gate = rdf64(image + STAC_MODEL_OFF_BASE_GATE);
    m->base_stuck = rd32(image + STAC_MODEL_OFF_BASE_STUCK);
    m->contact_force = rdf64(image + STAC_MODEL_OFF_CONTACT_FORCE);
    m->n_base = (uint16_t)(m->steps * STAC_MODEL_CHANNELS);

    /* dimensions: the limits, and the sizes the layout implies */
    const uint32_t n_std = m->uncertainty ? m->n_reg : 0u;
    const uint32_t per = 1u + m->n_lags + m->n_emas + (m->drift ? 1u : 0u);
    if (m->weight_format > STAC_MODEL_W_I8 || m->arch > STAC_MODEL_ARCH_RESMLP ||
        image[STAC_MODEL_OFF_CHANNELS] != STAC_MODEL_CHANNELS || m->steps < 1u ||
        m->steps > STAC_MODEL_MAX_STEPS ||
        m->n_lags > STAC_MODEL_MAX_LAGS || m->n_emas > STAC_MODEL_MAX_EMAS || m->drift > 1u ||
        m->n_in != m->n_base * per || m->n_in > STAC_MODEL_MAX_INPUTS ||
        m->n_feat > STAC_MODEL_MAX_FEATURES || m->n_feat != m->n_lin + m->n_rat ||
        m->n_feat == 0u || m->hidden > STAC_MODEL_MAX_HIDDEN ||
        m->blocks > STAC_MODEL_MAX_BLOCKS || m->n_out > STAC_MODEL_MAX_OUTPUTS ||
        m->n_out != m->n_reg + n_std + m->n_classes + m->contact_head || m->n_out == 0u ||
        m->n_dark > STAC_MODEL_MAX_DARK || (flags & ~STAC_MODEL_FLAGS_DEFINED) != 0u)
        return fail(m);
    if (m->arch == STAC_MODEL_ARCH_LINEAR ? (m->hidden != 0u || m->blocks != 0u)
                                          : m->hidden == 0u)
        return fail(m);
    if (m->arch == STAC_MODEL_ARCH_MLP && m->blocks == 0u) return fail(m);
    for (unsigned i = 0; i < STAC_MODEL_N_TARGETS; ++i)
        if (m->target_map[i] != STAC_MODEL_TARGET_ABSENT && m->target_map[i] >= m->n_reg)
            return fail(m);
    if (!(m->base_tau >= 1.0) || !(m->base_gate >= 0.0) || !isfinite(m->base_gate) ||
        !isfinite(m->base_tau) || !(m->saturation >= 0.0f) || !isfinite(m->dark_counts) ||
        !isfinite(m->contact_force) || rd32(image + STAC_MODEL_OFF_RESERVED0) != 0u ||
        rd32(image + STAC_MODEL_OFF_RESERVED1) != 0u)
        return fail(m);

    reader_t r = {image, size, table_end, 1};
    m->lags = (const uint16_t *)(const void *)section(&r, STAC_MODEL_SEC_LAGS, 2u * m->n_lags);
    const uint8_t *alpha = section(&r, STAC_MODEL_SEC_EMA_ALPHA, 8u * m->n_emas);
    m->center = (const float *)(const void *)section(&r, STAC_MODEL_SEC_CENTER, 4u * m->n_in);
    open_csr(&r, STAC_MODEL_SEC_LIN_PTR, m->n_lin, m->n_in, &m->lin);
    open_csr(&r, STAC_MODEL_SEC_P_PTR, m->n_rat, m->n_in, &m->rat_p);
    open_csr(&r, STAC_MODEL_SEC_Q_PTR, m->n_rat, m->n_in, &m->rat_q);
    m->f_mean = (const float *)(const void *)section(&r, STAC_MODEL_SEC_F_MEAN, 4u * m->n_feat);
    m->f_std = (const float *)(const void *)section(&r, STAC_MODEL_SEC_F_STD, 4u * m->n_feat);
    if (!r.ok) return fail(m);

    /* the linear layers, in networks.layer_shapes order */
    uint16_t dims[STAC_MODEL_MAX_LAYERS][2];
    const uint16_t n_hidden_layers = m->arch == STAC_MODEL_ARCH_LINEAR ? 0u
                                     : m->arch == STAC_MODEL_ARCH_MLP  ? (uint16_t)(m->blocks - 1u)
                                                                       : (uint16_t)(2u * m->blocks);
    uint16_t nl = 0;
    dims[nl][0] = m->n_feat;
    dims[nl][1] = m->arch == STAC_MODEL_ARCH_LINEAR ? m->n_out : m->hidden;
    ++nl;
    for (uint16_t k = 0; k < n_hidden_layers; ++k, ++nl) {
        dims[nl][0] = m->hidden;
        dims[nl][1] = m->hidden;
    }
    if (m->arch != STAC_MODEL_ARCH_LINEAR) {
        dims[nl][0] = m->hidden;
        dims[nl][1] = m->n_out;
        ++nl;
    }
    const uint32_t esize = m->weight_format == STAC_MODEL_W_F32   ? 4u
                           : m->weight_format == STAC_MODEL_W_F16 ? 2u
                                                                  : 1u;
    uint32_t n_w = 0, n_rows = 0;
    for (uint16_t l = 0; l < nl; ++l) {
        n_w += (uint32_t)dims[l][0] * dims[l][1];
        n_rows += dims[l][1];
    }
    const uint8_t *w = section(&r, STAC_MODEL_SEC_WEIGHTS, esize * n_w);
    const uint32_t n_scale = m->weight_format == STAC_MODEL_W_I8 ? n_rows : 0u;
    const float *scale =
        (const float *)(const void *)section(&r, STAC_MODEL_SEC_W_SCALE, 4u * n_scale);
    const float *bias = (const float *)(const void *)section(&r, STAC_MODEL_SEC_BIAS, 4u * n_rows);
    const uint32_t n_norm = m->arch == STAC_MODEL_ARCH_RESMLP
                                ? 2u * ((uint32_t)m->blocks + 1u) * m->hidden
                                : 0u;
    m->norms = (const float *)(const void *)section(&r, STAC_MODEL_SEC_NORMS, 4u * n_norm);
    m->y_scale = (const float *)(const void *)section(&r, STAC_MODEL_SEC_Y_SCALE, 4u * m->n_reg);
    m->std_mul = (const float *)(const void *)section(&r, STAC_MODEL_SEC_STD_MUL, 4u * n_std);
    m->t_lo = (const float *)(const void *)section(&r, STAC_MODEL_SEC_T_LO, 4u * m->n_reg);
    m->t_hi = (const float *)(const void *)section(&r, STAC_MODEL_SEC_T_HI, 4u * m->n_reg);
    m->in_lo = (const float *)(const void *)section(&r, STAC_MODEL_SEC_IN_LO, 4u * m->n_base);
    m->in_hi = (const float *)(const void *)section(&r, STAC_MODEL_SEC_IN_HI, 4u * m->n_base);
    m->dark_cols =
        (const uint16_t *)(const void *)section(&r, STAC_MODEL_SEC_DARK_COLS, 2u * m->n_dark);
    const uint32_t n_rest = (flags & STAC_MODEL_FLAG_REST) != 0u ? m->n_base : 0u;
    if (n_rest != 0u && !m->drift) return fail(m); /* a rest signature serves the baseline */
    const uint8_t *rest = section(&r, STAC_MODEL_SEC_REST, 8u * n_rest);
    const uint8_t *press = section(&r, STAC_MODEL_SEC_PRESS, 8u * n_rest);
    if (!r.ok) return fail(m);
    if (n_rest != 0u) { /* f64 sections are only 4-byte aligned: read byte-wise (rdf64) */
        m->rest = rest;
        m->press = press;
        double score = 0.0;
        for (uint32_t i = 0; i < n_rest; ++i) {
            const double v = rdf64(rest + 8u * i), d = rdf64(press + 8u * i);
            if (!isfinite(v) || !isfinite(d)) return fail(m);
            score += d * log(v > 1.0 ? v : 1.0);
        }
        m->rest_score = score;
    }
    for (uint16_t l = 0, row = 0; l < nl; ++l) {
        stac_model_layer_t *L = &m->layers[l];
        L->n_in = dims[l][0];
        L->n_out = dims[l][1];
        L->w = w;
        L->scale = n_scale ? scale + row : NULL;
        L->bias = bias + row;
        w += esize * (uint32_t)L->n_in * L->n_out;
        row = (uint16_t)(row + L->n_out);
    }
    m->n_layers = nl;

    /* contents: lags and moving averages usable, every float parameter finite */
    for (uint16_t k = 0; k < m->n_lags; ++k)
        if (m->lags[k] == 0u || m->lags[k] >= STAC_MODEL_MAX_HIST) return fail(m);
    m->hist = 1u;
    for (uint16_t k = 0; k < m->n_lags; ++k)
        if (m->lags[k] + 1u > m->hist) m->hist = (uint16_t)(m->lags[k] + 1u);
    for (uint16_t e = 0; e < m->n_emas; ++e) {
        m->ema_alpha[e] = rdf64(alpha + 8u * e);
        if (!(m->ema_alpha[e] > 0.0 && m->ema_alpha[e] <= 1.0)) return fail(m);
    }
    for (uint16_t k = 0; k < m->n_dark; ++k)
        if (m->dark_cols[k] >= m->n_base) return fail(m);
    for (uint16_t f = 0; f < m->n_feat; ++f)
        if (!(m->f_std[f] > 0.0f)) return fail(m);
    if (!all_finite(m->center, m->n_in) || !all_finite(m->lin.val, m->lin.ptr[m->n_lin]) ||
        !all_finite(m->rat_p.val, m->rat_p.ptr[m->n_rat]) ||
        !all_finite(m->rat_q.val, m->rat_q.ptr[m->n_rat]) ||
        !all_finite(m->f_mean, m->n_feat) || !all_finite(m->f_std, m->n_feat) ||
        !all_finite(scale, n_scale) || !all_finite(bias, n_rows) ||
        !all_finite(m->norms, n_norm) || !all_finite(m->y_scale, m->n_reg) ||
        !all_finite(m->std_mul, n_std))
        return fail(m);
    if (m->weight_format == STAC_MODEL_W_F32 &&
        !all_finite((const float *)(const void *)m->layers[0].w, n_w))
        return fail(m);
    return STAC_OK;
}

/* ------------------------------------------------------------------ network */

/* IEEE half to float: the FPU's VCVTB on ARMv7E-M (FPv4-SP and FPv5 have it; exact, and
 * FPSCR's reset value keeps subnormals and the IEEE half format), elsewhere bit by bit. */
#if defined(__ARM_ARCH_7EM__) && defined(__ARM_FP)
static inline __attribute__((always_inline)) float half_to_float(uint16_t h) {
    float f;
    const uint32_t bits = h;
    __asm("vmov %0, %1\n\tvcvtb.f32.f16 %0, %0" : "=t"(f) : "r"(bits));
    return f;
}
#else
static inline __attribute__((always_inline)) float half_to_float(uint16_t h) {
    const uint32_t sign = (uint32_t)(h & 0x8000u) << 16;
    uint32_t exp = (h >> 10) & 0x1Fu, man = h & 0x3FFu, bits;
    if (exp == 0u) {
        if (man == 0u) {
            bits = sign;
        } else { /* subnormal: normalise (at most 10 shifts) */
            exp = 113u;
            while ((man & 0x400u) == 0u) {
                man <<= 1;
                --exp;
            }
            bits = sign | (exp << 23) | ((man & 0x3FFu) << 13);
        }
    } else if (exp == 31u) {
        bits = sign | 0x7F800000u | (man << 13);
    } else {
        bits = sign | ((exp + 112u) << 23) | (man << 13);
    }
    float f;
    memcpy(&f, &bits, sizeof f);
    return f;
}
#endif

/* Dot products of one weight row with x, four independent accumulators (the FPU's
 * multiply-add latency overlaps, and four loads merge into one VLDM), summed pairwise. */
#define DOT4(load)                                                                   \
    do {                                                                             \
        float a0 = 0.0f, a1 = 0.0f, a2 = 0.0f, a3 = 0.0f;                            \
        uint32_t i = 0;                                                              \
        for (; i + 4u <= n; i += 4u) {                                               \
            a0 += load(i) * x[i];                                                    \
            a1 += load(i + 1u) * x[i + 1u];                                          \
            a2 += load(i + 2u) * x[i + 2u];                                          \
            a3 += load(i + 3u) * x[i + 3u];                                          \
        }                                                                            \
        for (; i < n; ++i) a0 += load(i) * x[i];                                     \
        return (a0 + a1) + (a2 + a3);                                                \
    } while (0)

#if defined(__ARM_ARCH_7EM__) && defined(__ARM_FP)
/* The same sums on the Cortex-M4F, with four weights and four inputs per VLDM (1 + 4 cycles
 * instead of 4 x 2): the network's hot loop. VMLA rounds the product like the C above
 * (-std=c11 does not contract), so the results are the same bit for bit. */
static float dot_f32(const float *row, const float *x, uint32_t n) {
    float a0 = 0.0f, a1 = 0.0f, a2 = 0.0f, a3 = 0.0f;
    const float *w = row, *v = x;
    uint32_t blocks = n / 4u;
    if (blocks != 0u) {
        __asm volatile(
            "1:\n\t"
            "vldmia %[w]!, {s8-s11}\n\t"
            "vldmia %[v]!, {s12-s15}\n\t"
            "vmla.f32 %[a0], s8, s12\n\t"
            "vmla.f32 %[a1], s9, s13\n\t"
            "vmla.f32 %[a2], s10, s14\n\t"
            "vmla.f32 %[a3], s11, s15\n\t"
            "subs %[k], %[k], #1\n\t"
            "bne 1b"
            : [w] "+r"(w), [v] "+r"(v), [k] "+r"(blocks), [a0] "+t"(a0), [a1] "+t"(a1),
              [a2] "+t"(a2), [a3] "+t"(a3)
            :
            : "s8", "s9", "s10", "s11", "s12", "s13", "s14", "s15", "cc", "memory");
    }
    for (uint32_t i = n & ~3u; i < n; ++i) a0 += row[i] * x[i];
    return (a0 + a1) + (a2 + a3);
}
#else
static float dot_f32(const float *row, const float *x, uint32_t n) {
#define LOAD_F32(k) row[k]
    DOT4(LOAD_F32);
}
#endif

static float dot_f16(const uint16_t *row, const float *x, uint32_t n) {
#define LOAD_F16(k) half_to_float(row[k])
    DOT4(LOAD_F16);
}

#if defined(__ARM_ARCH_7EM__) && defined(__ARM_FP)
/* int8 rows four at a time: one (unaligned, which ARMv7-M allows) word load, sign-extended
 * into four integers, two two-register VMOVs, four VCVTs; sums as in the C above. */
static float dot_i8(const int8_t *row, const float *x, uint32_t n) {
    float a0 = 0.0f, a1 = 0.0f, a2 = 0.0f, a3 = 0.0f;
    const int8_t *w = row;
    const float *v = x;
    uint32_t blocks = n / 4u, word, t0, t1, t2, t3;
    if (blocks != 0u) {
        __asm volatile(
            "1:\n\t"
            "ldr %[word], [%[w]], #4\n\t"
            "vldmia %[v]!, {s12-s15}\n\t"
            "sxtb %[t0], %[word]\n\t"
            "sbfx %[t1], %[word], #8, #8\n\t"
            "sbfx %[t2], %[word], #16, #8\n\t"
            "asr %[t3], %[word], #24\n\t"
            "vmov s8, s9, %[t0], %[t1]\n\t"
            "vmov s10, s11, %[t2], %[t3]\n\t"
            "vcvt.f32.s32 s8, s8\n\t"
            "vcvt.f32.s32 s9, s9\n\t"
            "vcvt.f32.s32 s10, s10\n\t"
            "vcvt.f32.s32 s11, s11\n\t"
            "vmla.f32 %[a0], s8, s12\n\t"
            "vmla.f32 %[a1], s9, s13\n\t"
            "vmla.f32 %[a2], s10, s14\n\t"
            "vmla.f32 %[a3], s11, s15\n\t"
            "subs %[k], %[k], #1\n\t"
            "bne 1b"
            : [w] "+r"(w), [v] "+r"(v), [k] "+r"(blocks), [word] "=&r"(word), [t0] "=&r"(t0),
              [t1] "=&r"(t1), [t2] "=&r"(t2), [t3] "=&r"(t3), [a0] "+t"(a0), [a1] "+t"(a1),
              [a2] "+t"(a2), [a3] "+t"(a3)
            :
            : "s8", "s9", "s10", "s11", "s12", "s13", "s14", "s15", "cc", "memory");
    }
    for (uint32_t i = n & ~3u; i < n; ++i) a0 += (float)row[i] * x[i];
    return (a0 + a1) + (a2 + a3);
}
#else
static float dot_i8(const int8_t *row, const float *x, uint32_t n) {
#define LOAD_I8(k) ((float)row[k])
    DOT4(LOAD_I8);
}
#endif

/* y = W x + b in the image's weight format. */
static void linear(const stac_model_t *m, const stac_model_layer_t *L, const float *x, float *y) {
    const uint32_t n_in = L->n_in;
    for (uint32_t o = 0; o < L->n_out; ++o) {
        if (m->weight_format == STAC_MODEL_W_F32) {
            y[o] = dot_f32((const float *)(const void *)L->w + o * n_in, x, n_in) + L->bias[o];
        } else if (m->weight_format == STAC_MODEL_W_F16) {
            y[o] = dot_f16((const uint16_t *)(const void *)L->w + o * n_in, x, n_in) + L->bias[o];
        } else {
            const float acc = dot_i8((const int8_t *)(const void *)L->w + o * n_in, x, n_in);
            y[o] = acc * L->scale[o] + L->bias[o];
        }
    }
}

static float gelu(float x) {
    return 0.5f * x * (1.0f + tanhf(GELU_K * (x + 0.044715f * x * x * x)));
}

static void layer_norm(const float *x, const float *g, const float *b, uint32_t n, float *y) {
    float mu = 0.0f, var = 0.0f;
    for (uint32_t i = 0; i < n; ++i) mu += x[i];
    mu /= (float)n;
    for (uint32_t i = 0; i < n; ++i) var += (x[i] - mu) * (x[i] - mu);
    var /= (float)n;
    const float inv = 1.0f / sqrtf(var + LN_EPS);
    for (uint32_t i = 0; i < n; ++i) y[i] = (x[i] - mu) * inv * g[i] + b[i];
}

/* Features of st->u into st->z (feature_matrices.FeatureSet.apply, then the scaler). */
static void features(const stac_model_t *m, stac_model_state_t *st) {
    const float *u = st->u;
    for (uint32_t f = 0; f < m->n_lin; ++f) {
        float acc = 0.0f;
        for (uint32_t k = m->lin.ptr[f]; k < m->lin.ptr[f + 1u]; ++k) {
            const uint16_t i = m->lin.idx[k];
            acc += m->lin.val[k] * (u[i] - m->center[i]);
        }
        st->z[f] = acc;
    }
    for (uint32_t f = 0; f < m->n_rat; ++f) {
        float num = 0.0f, den = 0.0f;
        for (uint32_t k = m->rat_p.ptr[f]; k < m->rat_p.ptr[f + 1u]; ++k)
            num += m->rat_p.val[k] * u[m->rat_p.idx[k]];
        for (uint32_t k = m->rat_q.ptr[f]; k < m->rat_q.ptr[f + 1u]; ++k)
            den += m->rat_q.val[k] * fabsf(u[m->rat_q.idx[k]]);
        st->z[m->n_lin + f] = num / (den + FEATURE_EPS);
    }
    for (uint32_t f = 0; f < m->n_feat; ++f) st->z[f] = (st->z[f] - m->f_mean[f]) / m->f_std[f];
}

/* The network on st->z; raw head values into st->out. */
static void network(const stac_model_t *m, stac_model_state_t *st) {
    const uint32_t H = m->hidden;
    if (m->arch == STAC_MODEL_ARCH_LINEAR) {
        linear(m, &m->layers[0], st->z, st->out);
        return;
    }
    linear(m, &m->layers[0], st->z, st->h);
    for (uint32_t i = 0; i < H; ++i) st->h[i] = gelu(st->h[i]);
    if (m->arch == STAC_MODEL_ARCH_MLP) {
        for (uint32_t l = 1; l < m->blocks; ++l) {
            linear(m, &m->layers[l], st->h, st->t);
            for (uint32_t i = 0; i < H; ++i) st->h[i] = gelu(st->t[i]);
        }
        linear(m, &m->layers[m->blocks], st->h, st->out);
        return;
    }
    for (uint32_t k = 0; k < m->blocks; ++k) {
        const float *g = m->norms + 2u * k * H;
        layer_norm(st->h, g, g + H, H, st->n);
        linear(m, &m->layers[1u + 2u * k], st->n, st->t);
        for (uint32_t i = 0; i < H; ++i) st->t[i] = gelu(st->t[i]);
        linear(m, &m->layers[2u + 2u * k], st->t, st->n);
        for (uint32_t i = 0; i < H; ++i) st->h[i] += st->n[i];
    }
    const float *g = m->norms + 2u * m->blocks * H;
    layer_norm(st->h, g, g + H, H, st->n);
    linear(m, &m->layers[m->n_layers - 1u], st->n, st->out);
}

/* heads.postprocess, in place on st->out */
static void heads(const stac_model_t *m, stac_model_state_t *st) {
    float *o = st->out;
    for (uint32_t r = 0; r < m->n_reg; ++r) o[r] *= m->y_scale[r];
    uint32_t at = m->n_reg;
    if (m->uncertainty) {
        for (uint32_t r = 0; r < m->n_reg; ++r) o[at + r] = expf(o[at + r]) * m->std_mul[r];
        at += m->n_reg;
    }
    if (m->n_classes) {
        float mx = o[at], sum = 0.0f;
        for (uint32_t c = 1; c < m->n_classes; ++c) mx = o[at + c] > mx ? o[at + c] : mx;
        for (uint32_t c = 0; c < m->n_classes; ++c) {
            o[at + c] = expf(o[at + c] - mx);
            sum += o[at + c];
        }
        for (uint32_t c = 0; c < m->n_classes; ++c) o[at + c] /= sum;
        at += m->n_classes;
    }
    if (m->contact_head) o[at] = 0.5f * (1.0f + tanhf(0.5f * o[at]));
}

/* ------------------------------------------------------------------ assembly */

void stac_model_reset(const stac_model_t *m, stac_model_state_t *st) {
    (void)m;
    const uint8_t tare = st->tare; /* a tare asked for before the stream starts */
    memset(st, 0, sizeof *st);
    st->tare = tare;
}

void stac_model_tare(stac_model_state_t *st) { st->tare = 1u; }

/* ------------------------------------------------------------------ drift baseline */

/* press . log(max(x, 1)) (rest_signature.log_counts): how far a sample is pressed. */
static double press_score(const stac_model_t *m, const double *x, uint32_t n) {
    double s = 0.0;
    for (uint32_t i = 0; i < n; ++i)
        s += rdf64(m->press + 8u * i) * log(x[i] > 1.0 ? x[i] : 1.0);
    return s;
}

/* RMS deviation of `cur` from `base` relative to |base| plus a floor (_Baseline._rel). */
static double rel_dev(const float *cur, const double *base, uint32_t n) {
    double sum_abs = 0.0, dev2 = 0.0;
    for (uint32_t i = 0; i < n; ++i) sum_abs += fabs(base[i]);
    const double floor_ = 1e-6 + 0.01 * sum_abs / (double)n;
    for (uint32_t i = 0; i < n; ++i) {
        const double dev = ((double)cur[i] - base[i]) / (fabs(base[i]) + floor_);
        dev2 += dev * dev;
    }
    return sqrt(dev2 / (double)n);
}

static void base_start(stac_model_state_t *st, const double *value, uint32_t n) {
    memcpy(st->base, value, n * sizeof(double));
    st->out_of_gate = 0u;
}

/* The first sample: rest at once without a signature (as models before it) or when the skin
 * is not pressed; else the model's rest stands in while the search follows the skin down. */
static void base_first(const stac_model_t *m, stac_model_state_t *st, const float *cur) {
    const uint32_t B = m->n_base;
    for (uint32_t i = 0; i < B; ++i) st->low[i] = (double)cur[i];
    base_start(st, st->low, B);
    if (m->rest == NULL) return; /* rest is never known to be seen */
    const double s = press_score(m, st->low, B);
    if (s <= m->rest_score + REST_JOIN) {
        st->rest_seen = 1u;
        return;
    }
    st->searching = st->on_rest = 1u;
    for (uint32_t i = 0; i < B; ++i) st->base[i] = rdf64(m->rest + 8u * i);
    st->low_score = s;
}

static void base_found(stac_model_state_t *st, uint32_t n) {
    base_start(st, st->low, n);
    st->searching = 0u;
    st->rest_seen = 1u;
}

/* One step of the search for rest (_Baseline._search). */
static void base_search(const stac_model_t *m, stac_model_state_t *st, const float *cur) {
    const uint32_t B = m->n_base;
    double x[STAC_MODEL_MAX_BASE];
    for (uint32_t i = 0; i < B; ++i) x[i] = (double)cur[i];
    const double s = press_score(m, x, B);
    if (s < st->low_score - REST_DROP) { /* came down: what was above was contact */
        memcpy(st->low, x, B * sizeof(double));
        st->low_score = s;
        st->armed = 1u;
        st->still = 0u;
    } else if (s > st->low_score + REST_DROP) { /* pressed (again) from the low */
        if (st->armed) {
            base_found(st, B);
            return;
        }
        st->still = 0u;
    } else if (rel_dev(cur, st->low, B) < m->base_gate) {
        ++st->still;
        for (uint32_t i = 0; i < B; ++i) /* the mean of the still stretch */
            st->low[i] += (x[i] - st->low[i]) / (double)(st->still + 1u);
        st->low_score = press_score(m, st->low, B);
    }
    if (st->armed && st->still >= REST_STILL) {
        base_found(st, B);
    } else if (st->still >= REST_HOLD && st->on_rest) {
        st->on_rest = 0u; /* this skin, still for a while: better than another's rest */
        memcpy(st->base, st->low, B * sizeof(double));
    } else if (!st->on_rest) {
        memcpy(st->base, st->low, B * sizeof(double));
    }
}

/* The baseline as it was before the sample into `dst`, then its update (_Baseline.step). */
static void baseline(const stac_model_t *m, stac_model_state_t *st, const float *cur, float *dst) {
    const uint32_t B = m->n_base;
    if (st->tare) { /* the user says the skin is at rest: this sample is the zero */
        st->tare = st->searching = 0u;
        st->rest_seen = st->base_ready = 1u;
        for (uint32_t i = 0; i < B; ++i) st->low[i] = (double)cur[i];
        base_start(st, st->low, B);
        memcpy(dst, cur, B * sizeof(float));
        return;
    }
    if (!st->base_ready) {
        base_first(m, st, cur);
        st->base_ready = 1u;
        for (uint32_t i = 0; i < B; ++i) dst[i] = (float)st->base[i];
        return;
    }
    for (uint32_t i = 0; i < B; ++i) dst[i] = (float)st->base[i];
    if (st->searching) {
        base_search(m, st, cur);
        return;
    }
    const double rel = rel_dev(cur, st->base, B);
    st->out_of_gate = rel < m->base_gate ? 0u : st->out_of_gate + 1u;
    if (st->out_of_gate == 0u || st->out_of_gate > m->base_stuck)
        for (uint32_t i = 0; i < B; ++i)
            st->base[i] += ((double)cur[i] - st->base[i]) / m->base_tau;
}

/* assemble.Assembler.push after the latest sample of every step is known: history, lags,
 * moving averages (the past only), baseline (as it was before the sample). */
static void assemble(const stac_model_t *m, stac_model_state_t *st) {
    const uint32_t B = m->n_base, H = m->hist;
    const float *cur = st->latest;
    if (st->n_assembled == 0u) { /* early lags repeat the oldest sample there is */
        for (uint32_t k = 0; k < H; ++k) memcpy(st->hist[k], cur, B * sizeof(float));
    }
    st->hist_head = (uint16_t)((st->hist_head + 1u) % H);
    memcpy(st->hist[st->hist_head], cur, B * sizeof(float));
    if (st->n_assembled < UINT32_MAX) ++st->n_assembled;
    memcpy(st->u, cur, B * sizeof(float));
    for (uint32_t k = 0; k < m->n_lags; ++k) {
        const float *h = st->hist[(st->hist_head + H - m->lags[k]) % H];
        memcpy(st->u + (1u + k) * B, h, B * sizeof(float));
    }
    if (m->n_emas && !st->ema_ready) {
        for (uint32_t e = 0; e < m->n_emas; ++e)
            for (uint32_t i = 0; i < B; ++i) st->ema[e][i] = (double)cur[i];
        st->ema_ready = 1u;
    }
    for (uint32_t e = 0; e < m->n_emas; ++e) {
        float *dst = st->u + (1u + m->n_lags + e) * B;
        for (uint32_t i = 0; i < B; ++i) {
            dst[i] = (float)st->ema[e][i];
            st->ema[e][i] += m->ema_alpha[e] * ((double)cur[i] - st->ema[e][i]);
        }
    }
    if (m->drift) baseline(m, st, cur, st->u + m->n_in - B);
}

/* ------------------------------------------------------------------ one sample */

static void no_estimate(stac_model_output_t *out, uint8_t flags) {
    for (unsigned i = 0; i < STAC_FORCE_AXES; ++i) out->force[i] = out->torque[i] = NAN;
    out->region = 0u;
    out->region_prob = NAN;
    out->contact_prob = NAN;
    out->flags = flags;
}

int stac_model_push(const stac_model_t *m, stac_model_state_t *st, uint8_t led_step,
                    const uint16_t counts[STAC_SENSORS][STAC_CHANNELS],
                    const uint8_t sensor_status[STAC_SENSORS], stac_model_output_t *out) {
    if (m->image == NULL || led_step >= m->steps) {
        no_estimate(out, STAC_EST_INVALID);
        return 1;
    }
    float *x = st->latest + (uint32_t)led_step * STAC_MODEL_CHANNELS;
    for (uint32_t s = 0; s < STAC_SENSORS; ++s)
        for (uint32_t c = 0; c < PER_SENSOR; ++c) x[s * PER_SENSOR + c] = (float)counts[s][c];
    st->seen[led_step] = 1u;
    for (uint32_t s = 0; s < m->steps; ++s)
        if (!st->seen[s]) return 0;
    assemble(m, st);
    features(m, st);
    network(m, st);
    heads(m, st);

    uint8_t flags = st->n_assembled < m->hist ? (uint8_t)STAC_EST_WARMUP : 0u;
    if (m->drift && !st->rest_seen) flags |= STAC_EST_NO_REST;
    for (uint32_t i = 0; i < m->n_out; ++i)
        if (!isfinite(st->out[i])) { /* damaged weights or overflow: no estimate */
            no_estimate(out, (uint8_t)(flags | STAC_EST_INVALID));
            return 1;
        }
    /* guard.Guard.check on the current sample, the targets and the status */
    int ood = 0;
    for (uint32_t i = 0; i < m->n_base; ++i) {
        const float v = st->u[i];
        if (v < m->in_lo[i] || v > m->in_hi[i]) ood = 1;
        if (m->saturation > 0.0f && v >= m->saturation) ood = 1;
    }
    for (uint32_t k = 0; k < m->n_dark; ++k)
        if (st->u[m->dark_cols[k]] < m->dark_counts) ood = 1;
    for (uint32_t r = 0; r < m->n_reg; ++r)
        if (st->out[r] < m->t_lo[r] || st->out[r] > m->t_hi[r]) ood = 1;
    for (uint32_t s = 0; s < STAC_SENSORS; ++s)
        if (sensor_status[s] & STATUS_BAD) ood = 1;
    if (ood) flags |= STAC_EST_OOD;

    double f2 = 0.0; /* decoder.py: |F| from the float32 outputs in float64 */
    int any_force = 0;
    for (unsigned i = 0; i < STAC_FORCE_AXES; ++i) {
        const uint8_t fi = m->target_map[i], ti = m->target_map[STAC_FORCE_AXES + i];
        out->force[i] = fi == STAC_MODEL_TARGET_ABSENT ? NAN : st->out[fi];
        out->torque[i] = ti == STAC_MODEL_TARGET_ABSENT ? NAN : st->out[ti];
        if (fi != STAC_MODEL_TARGET_ABSENT) {
            f2 += (double)out->force[i] * (double)out->force[i];
            any_force = 1;
        }
    }
    const uint32_t cls = m->n_reg + (m->uncertainty ? m->n_reg : 0u);
    out->region = 0u;
    out->region_prob = NAN;
    if (m->n_classes) {
        uint32_t best = 0;
        for (uint32_t c = 1; c < m->n_classes; ++c)
            if (st->out[cls + c] > st->out[cls + best]) best = c;
        out->region = (uint8_t)(best + 1u);
        out->region_prob = st->out[cls + best];
    }
    if (m->contact_head) {
        out->contact_prob = st->out[m->n_out - 1u];
        if (out->contact_prob > 0.5f) flags |= STAC_EST_CONTACT;
    } else {
        out->contact_prob = NAN;
        if (any_force && sqrt(f2) > m->contact_force) flags |= STAC_EST_CONTACT;
    }
    out->flags = flags;
    return 1;
}
