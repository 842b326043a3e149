/* Hardware abstraction between the portable core and a port (native simulation or STM32F411).
 *
 * Every function is non-blocking or bounded: the core never waits on the hardware without a
 * timeout, so a dead sensor or a stuck bus shows up in frames instead of hanging the device.
 * Only plain C types cross this boundary so that the native port can hand it to ctypes. */
#ifndef STAC_HAL_H
#define STAC_HAL_H

#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Result of one I2C transfer. */
enum {
    STAC_I2C_OK = 0,
    STAC_I2C_NACK = 1,      /* address or data byte not acknowledged (sensor missing) */
    STAC_I2C_TIMEOUT = 2,   /* the transfer did not finish within timeout_us (bus stalled) */
    STAC_I2C_BUS_ERROR = 3  /* arbitration lost, bus error, or any other failure */
};

#define STAC_UID_SIZE 12u

/* Result of one model-store (flash) operation. */
enum {
    STAC_FLASH_OK = 0,
    STAC_FLASH_FAILED = 1,  /* the controller reported an error, or a read-back differs */
    STAC_FLASH_TIMEOUT = 2, /* the operation did not finish within its bound */
    STAC_FLASH_BAD_ARG = 3  /* offset or length unaligned or outside the store */
};

/* store_program takes whole words: offset and length are multiples of this. */
#define STAC_FLASH_WORD 4u

typedef struct stac_hal {
    void *ctx; /* passed back unchanged as the first argument of every call */

    /* Write wr_len bytes to 7-bit address addr7 on bus (0..2); when rd_len > 0 follow with a
     * repeated start and read rd_len bytes. Returns a STAC_I2C_* code within timeout_us. */
    int32_t (*i2c_transfer)(void *ctx, uint8_t bus, uint8_t addr7, const uint8_t *wr,
                            uint32_t wr_len, uint8_t *rd, uint32_t rd_len, uint32_t timeout_us);

    /* Set the PWM duty of one colour (0 R, 1 G, 2 B) of one LED (0..2), in permille. */
    void (*pwm_set)(void *ctx, uint8_t led, uint8_t colour, uint16_t duty_permille);

    /* The host link: whatever carries frames to and from the host (USB CDC-ACM or a UART on
     * the STM32 port, the caller's callbacks on the native one).
     * link_write queues a whole encoded frame for transmission. All or nothing: returns len
     * when queued, 0 when the transmit buffer cannot take it (the core then counts a dropped
     * frame). */
    uint32_t (*link_write)(void *ctx, const uint8_t *data, uint32_t len);

    /* Copy up to cap received bytes into buf without waiting; returns how many. */
    uint32_t (*link_read)(void *ctx, uint8_t *buf, uint32_t cap);

    /* Monotonic microseconds, wrapping at 2^32. */
    uint32_t (*clock_us)(void *ctx);

    /* The 96-bit unique id of the device. */
    void (*unique_id)(void *ctx, uint8_t uid[STAC_UID_SIZE]);

    /* Model store: a flash region that keeps an uploaded decoder across resets. A port
     * without one leaves all four NULL (the core then reports a capacity of 0).
     * store_capacity: its size in bytes (a multiple of STAC_FLASH_WORD).
     * store_data: the region, memory-mapped for reading (erased bytes read 0xFF).
     * store_erase: set every byte of [offset, offset + len) to 0xFF (both multiples of
     * STAC_FLASH_WORD, inside the region). Flash that erases in larger units (sectors) may
     * erase more of the region around the range, never less, so a caller must treat every
     * other byte of the region as possibly erased too. A STAC_FLASH_* code within a bounded
     * time (the bound grows with the number of sectors the range touches).
     * store_program: write len bytes at offset (both multiples of STAC_FLASH_WORD, inside the
     * region); programming only clears bits, so the bytes must have been erased (or the
     * write must only clear bits). A STAC_FLASH_* code within a bounded time. */
    uint32_t (*store_capacity)(void *ctx);
    const uint8_t *(*store_data)(void *ctx);
    int32_t (*store_erase)(void *ctx, uint32_t offset, uint32_t len);
    int32_t (*store_program)(void *ctx, uint32_t offset, const uint8_t *data, uint32_t len);

    /* Optional (NULL when the port has none). watchdog_refresh: restart the port's watchdog
     * period; the core calls it inside its long loops (the model store's CRC pass over up to
     * 448 KiB), which would otherwise outlast a short watchdog period.
     * cycles: a free-running CPU cycle counter (DWT->CYCCNT on the STM32, wrapping at 2^32),
     * with cycle_hz its rate; the core measures acquisition and decoding with it and reports
     * 0 Hz ("not measured") without one. */
    void (*watchdog_refresh)(void *ctx);
    uint32_t (*cycles)(void *ctx);
    uint32_t cycle_hz;

    /* Optional (NULL: the device answers the command with a NACK; protocol 1.4).
     * enter_bootloader: called once ENTER_BOOTLOADER's ACK has been handed to link_write; the
     * port lets the link drain (bounded), then restarts in its ROM bootloader. On a board it
     * does not return; a simulated port may return and close its link.
     * debug_fault: test images only (a release image leaves it NULL and answers NACK
     * NOT_A_TEST_IMAGE); called after the ACK with a STAC_FAULT_* kind: fault or hang. */
    void (*enter_bootloader)(void *ctx);
    void (*debug_fault)(void *ctx, uint8_t kind);
} stac_hal_t;

#ifdef __cplusplus
}
#endif
#endif /* STAC_HAL_H */
