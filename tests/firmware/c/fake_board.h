/* A fake board for the core's unit tests: three register-level VEML3328 models on three
 * buses, a PWM recorder, a UART that captures frames and a settable clock. A sensor can be
 * made to NACK (absent), stall (timeout), answer with a wrong ID, never finish, or saturate. */
#ifndef FAKE_BOARD_H
#define FAKE_BOARD_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "stac_app.h"
#include "stac_frame.h"

enum fake_mode {
    FAKE_OK = 0,
    FAKE_ABSENT,     /* every transfer NACKs */
    FAKE_STALL,      /* every transfer times out (the clock advances by the timeout) */
    FAKE_WRONG_ID,   /* answers, but ID register low byte is not 0x28 */
    FAKE_NEVER_DONE, /* TRIG never clears */
    FAKE_BUS_ERROR   /* every transfer fails with a bus error */
};

typedef struct fake_sensor {
    int mode;
    uint16_t conf;
    uint16_t base[5];    /* counts R, G, B, C, IR in the dark */
    uint16_t data[5];    /* latched result registers */
    bool saturate;       /* results read 65535 */
    bool measuring;
    uint32_t trig_at;
    uint32_t it_us;
    uint32_t led_sum_at_trigger; /* sum of all duties when the measurement started */
    uint32_t triggers;
    uint32_t transfers;
    uint32_t fail_next;  /* the next n transfers fail as `fail_mode` */
    int fail_mode;
    uint32_t slow_ppm;   /* the sensor's oscillator runs this much slower than nominal */
    bool fresh;          /* finished, and the firmware has not yet seen TRIG cleared */
} fake_sensor_t;

typedef struct fake_pwm_event {
    uint32_t t;
    uint8_t led, colour;
    uint16_t duty;
} fake_pwm_event_t;

typedef struct fake_window {
    uint32_t start, end; /* integration of one sensor, for straddle checks */
    uint8_t bus;
} fake_window_t;

/* The model store: NOR-like flash (program only clears bits, read back and compared) that
 * erases whole sectors of unequal sizes, as the STM32's does (there 64 + 3 x 128 KiB). */
#define FAKE_FLASH_SIZE 32768u
#define FAKE_FLASH_SECTORS 4u
extern const uint32_t fake_flash_sector_start[FAKE_FLASH_SECTORS + 1u]; /* byte offsets */

#define FAKE_CYCLE_HZ 96000000u
#define FAKE_CYCLES_PER_READ 1000u

#define FAKE_MAX_PWM 4096
#define FAKE_MAX_WINDOWS 4096
#define FAKE_TX_CAP 65536
#define FAKE_RX_CAP 8192

typedef struct fake_board {
    fake_sensor_t s[3];
    uint32_t now;
    uint32_t transfer_cost_us; /* each I2C transfer advances the clock by this much */
    uint16_t duty[3][3];
    fake_pwm_event_t pwm[FAKE_MAX_PWM];
    size_t n_pwm;
    fake_window_t win[FAKE_MAX_WINDOWS];
    size_t n_win;
    uint8_t tx[FAKE_TX_CAP];
    size_t tx_len;
    bool tx_full;       /* refuse frames (transmit buffer full) */
    uint32_t tx_frames;
    uint32_t pass;              /* superloop passes run by fake_run_until */
    uint32_t done_pass;         /* pass in which the firmware last saw a measurement finish */
    uint32_t tx_pass[1024];     /* per captured frame: the pass that sent it */
    uint32_t tx_done_pass[1024];/* per captured frame: done_pass at that moment */
    uint32_t tx_triggers[1024]; /* per captured frame: sensor 0's triggers so far */
    uint32_t watchdog_refreshes; /* HAL watchdog_refresh calls */
    uint32_t cycle_count;        /* the fake cycle counter (FAKE_CYCLES_PER_READ per read) */
    uint8_t rx[FAKE_RX_CAP];
    size_t rx_len, rx_pos;
    _Alignas(8) uint8_t flash[FAKE_FLASH_SIZE];
    uint32_t flash_erases, flash_programs; /* operations run */
    uint32_t sector_erases[FAKE_FLASH_SECTORS]; /* per sector: how often it was erased */
    uint32_t flash_fail_at;    /* operation number (erases + programs, 1-based) that fails; 0 none */
    bool flash_power_cut;      /* with flash_cut_words: the supply fails during programming */
    uint32_t flash_cut_words;  /* words programmed before the power cut */
    bool flash_dead;           /* the cut happened: nothing more reaches the flash */
    uint32_t erase_us_per_sector; /* a sector erase advances cycle counter and clock this much */
    stac_boot_t boot;          /* what the port reports at boot (fake_boot copies it) */
    uint32_t bootloader_calls; /* HAL enter_bootloader calls */
    uint32_t fault_calls;      /* HAL debug_fault calls */
    uint8_t fault_kind;        /* the last one's kind */
    size_t tx_len_at_hook;     /* captured bytes when the last of those two hooks ran */
    stac_hal_t hal;
} fake_board_t;

void fake_init(fake_board_t *b);
/* Give the HAL the hooks of a test image: enter_bootloader and debug_fault (recorded). */
void fake_test_image(fake_board_t *b);
/* Start an app on the board: boot at b->now. */
void fake_boot(fake_board_t *b, stac_app_t *app);
/* Step the app every `tick_us` until `until` (absolute device time). */
void fake_run_until(fake_board_t *b, stac_app_t *app, uint32_t until, uint32_t tick_us);
/* Queue a command frame for the device. */
void fake_send(fake_board_t *b, uint8_t type, uint16_t seq, const uint8_t *payload, size_t len);
void fake_send_raw(fake_board_t *b, const uint8_t *bytes, size_t len);

/* Decoded frames the device sent, in order. */
typedef struct fake_frame {
    stac_frame_header_t h;
    uint8_t payload[STAC_MAX_PAYLOAD];
    size_t len;
} fake_frame_t;

/* Decode every captured frame into out (capacity cap); returns the count, -1 on a bad one. */
int fake_frames(const fake_board_t *b, fake_frame_t *out, size_t cap);
/* The last frame of a type, or NULL. */
const fake_frame_t *fake_last(const fake_frame_t *f, int n, uint8_t type);
int fake_count(const fake_frame_t *f, int n, uint8_t type);
void fake_clear_tx(fake_board_t *b);

#endif /* FAKE_BOARD_H */
