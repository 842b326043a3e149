/* SpectraTac firmware core as a host shared library (libstac_sim.so): the C ABI.
 *
 * The caller plays the hardware. It supplies callbacks for the I2C buses, the LED PWM and
 * the UART transmitter, feeds received bytes in, and drives time by calling stac_sim_step()
 * with its own (simulated) microsecond clock. Nothing in the library sleeps, allocates or uses
 * globals: each device is one caller-allocated instance of stac_sim_sizeof() bytes (8-byte
 * aligned), so any number of simulated devices can run in one process.
 *
 * Time: the core sees the clock only through stac_sim_step(sim, now_us) and, within one step,
 * through the optional clock_us callback (NULL: the step's now_us). now_us is a wrapping
 * 32-bit microsecond count that must not go backwards. Between steps nothing happens; call
 * stac_sim_step() again by stac_sim_next_wake_us() (earlier is fine) and after feeding bytes.
 *
 * Using it from Python ctypes (sketch):
 *   lib = ctypes.CDLL("libstac_sim.so")
 *   I2C = CFUNCTYPE(c_int32, c_void_p, c_uint32, c_uint8, c_uint8, POINTER(c_uint8), c_uint32,
 *                   POINTER(c_uint8), c_uint32, c_uint32)
 *   PWM = CFUNCTYPE(None, c_void_p, c_uint32, c_uint8, c_uint8, c_uint16)
 *   TX  = CFUNCTYPE(c_uint32, c_void_p, c_uint32, POINTER(c_uint8), c_uint32)
 *   CLK = CFUNCTYPE(c_uint32, c_void_p)
 *   class Callbacks(Structure): _fields_ = [("user", c_void_p), ("i2c_transfer", I2C),
 *       ("pwm_set", PWM), ("uart_tx", TX), ("clock_us", CLK)]
 *   sim = (c_uint64 * ((lib.stac_sim_sizeof() + 7) // 8))()
 *   lib.stac_sim_init(sim, byref(callbacks), b"native-sim", caps, uid12, 0, now_us)
 * Keep the CFUNCTYPE objects alive as long as the instance. A Python callback must not raise
 * (ctypes would print and return 0): catch the model's NACK exception and return
 * STAC_I2C_NACK (1). clock_us may be left NULL (ctypes: CLK() or None-typed cast). */
#ifndef STAC_SIM_H
#define STAC_SIM_H

#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#if defined(__GNUC__)
#define STAC_SIM_API __attribute__((visibility("default")))
#else
#define STAC_SIM_API
#endif

#define STAC_SIM_ABI_VERSION 1u
#define STAC_SIM_RX_CAPACITY 4096u /* received bytes buffered between two steps */

/* I2C transfer results (same values as the core's STAC_I2C_*). */
#define STAC_SIM_I2C_OK 0
#define STAC_SIM_I2C_NACK 1
#define STAC_SIM_I2C_TIMEOUT 2
#define STAC_SIM_I2C_BUS_ERROR 3

typedef struct stac_sim_callbacks {
    void *user; /* handed back as the first argument of every callback */

    /* Write wr_len bytes to the 7-bit address on bus (0..2, sensor k on bus k), then, if
     * rd_len > 0, repeated start and fill rd with rd_len bytes. A VEML3328 register read is
     * wr = [reg], rd_len = 2 (little-endian); a register write is wr = [reg, lsb, msb].
     * Return a STAC_SIM_I2C_* code; now_us is the device time of the transfer. */
    int32_t (*i2c_transfer)(void *user, uint32_t now_us, uint8_t bus, uint8_t addr7,
                            const uint8_t *wr, uint32_t wr_len, uint8_t *rd, uint32_t rd_len,
                            uint32_t timeout_us);

    /* LED `led` (0..2) colour `colour` (0 R, 1 G, 2 B) now runs at duty_permille (0..1000). */
    void (*pwm_set)(void *user, uint32_t now_us, uint8_t led, uint8_t colour,
                    uint16_t duty_permille);

    /* One complete encoded frame (0x00 delimiter included). Return len if taken, 0 to make
     * the device count it as dropped (transmit buffer full). */
    uint32_t (*uart_tx)(void *user, uint32_t now_us, const uint8_t *data, uint32_t len);

    /* Optional (may be NULL): the device clock within a step, for callers that model time
     * passing during I2C transfers. Must lie between this step's now_us and the next. */
    uint32_t (*clock_us)(void *user);
} stac_sim_callbacks_t;

typedef struct stac_sim stac_sim_t; /* opaque; allocate stac_sim_sizeof() bytes */

STAC_SIM_API uint32_t stac_sim_abi_version(void);
STAC_SIM_API uint32_t stac_sim_sizeof(void);

/* Capabilities the core implements plus CAP_SIMULATED: the usual value for `capabilities`. */
STAC_SIM_API uint32_t stac_sim_default_capabilities(void);

/* Set up an instance and probe the sensors through the callbacks (ID reads at now_us).
 * board: NUL-terminated, at most 15 characters used (NULL: "native-sim"); uid: 12 bytes
 * (NULL: zeros); baud: reported in INFO (0: not a UART). Returns 0, or -1 on a NULL sim,
 * callbacks or missing i2c_transfer / pwm_set / uart_tx. The device is silent until asked. */
STAC_SIM_API int32_t stac_sim_init(stac_sim_t *sim, const stac_sim_callbacks_t *callbacks,
                                   const char *board, uint32_t capabilities,
                                   const uint8_t *uid, uint32_t baud, uint32_t now_us);

/* One superloop pass at device time now_us: decode fed bytes, answer commands, run the
 * acquisition (trigger / poll / read sensors, send SAMPLEs through uart_tx). */
STAC_SIM_API void stac_sim_step(stac_sim_t *sim, uint32_t now_us);

/* Queue bytes received from the host; returns how many were taken (the rest did not fit:
 * step, then feed them again). */
STAC_SIM_API uint32_t stac_sim_rx_feed(stac_sim_t *sim, const uint8_t *data, uint32_t len);

/* Device time by which the next stac_sim_step() should run (the current step's time while
 * fed bytes are still waiting: one pass reads at most 512 of them). */
STAC_SIM_API uint32_t stac_sim_next_wake_us(const stac_sim_t *sim);

/* 1 while streaming SAMPLEs, else 0. */
STAC_SIM_API uint32_t stac_sim_streaming(const stac_sim_t *sim);

/* ---- Additions within ABI 1 (existing entry points unchanged) ----------------------------
 *
 * 64-bit time: the instance keeps an unwrapped microsecond clock (stac_sim_step unwraps its
 * 32-bit argument forwards); stac_sim_step64 sets it directly. A 32-bit time t inside a step
 * maps to now64 + ((t - now64) mod 2^32) mod 2^31. */
STAC_SIM_API void stac_sim_step64(stac_sim_t *sim, uint64_t now_us);
STAC_SIM_API uint64_t stac_sim_now64(const stac_sim_t *sim);

/* Free-running: while streaming and no fed bytes wait, step at each next wake-up time (what a
 * caller running "as fast as possible" does), at most max_steps times; returns the steps run. */
STAC_SIM_API uint32_t stac_sim_run(stac_sim_t *sim, uint32_t max_steps);

/* Sensor models inside the library (a test double of the three VEML3328s, veml_model.h):
 * register reads and writes are answered in C, and the caller is asked only for the counts of
 * each completed integration window. The caller may hand over counts it computed ahead for
 * windows it expects (a plan); a window that matches the plan entry a sensor is due to read
 * (same start, end and CONF window bits) is answered from it without a callback. */
#define STAC_SIM_PLAN_MAX 256u
/* A plan entry already read by one sensor is shared with another sensor only while it is among
 * the last this many windows evaluated (the twin's cache of window optics). */
#define STAC_SIM_SHARED_WINDOWS 8u

/* Counts (R, G, B, C, IR) for sensor's window [t0, t1) under CONF `conf`; return 0, or nonzero
 * if they cannot be computed (the firmware then sees a bus error). `user` as in callbacks. */
typedef int32_t (*stac_sim_window_fn)(void *user, uint8_t sensor, uint64_t t0_us, uint64_t t1_us,
                                      uint16_t conf, uint16_t *counts, uint8_t *saturated);

typedef struct stac_sim_window {
    uint64_t t0_us;
    uint64_t t1_us;
    uint16_t conf; /* CONF bits the counts depend on: IT, SENS, gain, DG, SD_ALS (0x7C70) */
    uint16_t counts[3][5]; /* per sensor: R, G, B, C, IR */
    uint8_t saturated[3];
    uint8_t reserved[5];
} stac_sim_window_t; /* 56 bytes, no implicit padding */

/* Like stac_sim_init, with the sensor models on buses 0..2 (bit k of present_mask: a sensor
 * answers on bus k). callbacks->i2c_transfer is not used and may be NULL. */
STAC_SIM_API int32_t stac_sim_init_models(stac_sim_t *sim, const stac_sim_callbacks_t *callbacks,
                                          stac_sim_window_fn window, uint32_t present_mask,
                                          const char *board, uint32_t capabilities,
                                          const uint8_t *uid, uint32_t baud, uint32_t now_us);

/* Replace the plan with n (<= STAC_SIM_PLAN_MAX) windows copied from `windows`. next[k]: the
 * entry sensor k reads next; evaluated: entries already evaluated (read by some sensor). Any
 * LED change drops the plan. Returns n taken (0 if the instance has no models). */
STAC_SIM_API uint32_t stac_sim_plan(stac_sim_t *sim, const stac_sim_window_t *windows, uint32_t n,
                                    const uint32_t next[3], uint32_t evaluated);

/* How far the sensors got in the plan (also after it was dropped). */
STAC_SIM_API void stac_sim_plan_progress(const stac_sim_t *sim, uint32_t next[3],
                                         uint32_t *evaluated);

/* One transfer straight to sensor model `bus` at time now_us (tests): a STAC_SIM_I2C_* code,
 * or -1 without models. */
STAC_SIM_API int32_t stac_sim_sensor_transfer(stac_sim_t *sim, uint8_t bus, uint64_t now_us,
                                              const uint8_t *wr, uint32_t wr_len, uint8_t *rd,
                                              uint32_t rd_len);

#ifdef __cplusplus
}
#endif
#endif /* STAC_SIM_H */
