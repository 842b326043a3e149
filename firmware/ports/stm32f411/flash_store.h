/* The model store in the STM32F411's flash: sectors 4-7, the 448 KiB from 0x0801_0000 to the
 * end of flash (0x0807_FFFF), which the linker script keeps free of code and data (the
 * program has sectors 0-3, the first 64 KiB).
 *
 * Register sequences from RM0383 (STM32F411xC/E reference manual) section 3 "Embedded Flash
 * memory interface": table 4 (sector map), 3.5.1 unlocking (FLASH_KEYR keys), 3.5.3 sector
 * erase (SER, SNB, STRT), 3.5.4 programming (PG, PSIZE x32 for a 2.7..3.6 V supply), 3.7 error
 * flags, 3.8 register map; 3.4.2 (ART accelerator) for resetting the caches after the
 * contents changed.
 *
 * An erase takes a byte range and erases every sector it touches, one after the other, each
 * wait bounded by that sector's own timeout; before each sector the `before_erase` hook runs
 * (the port refreshes the watchdog there). The register block, the mapped region and its
 * sector table are parameters so that the native C tests run the same code against a fake
 * block (tests/firmware/c/test_flash_store.c). While the flash erases or programs, a CPU
 * fetching code from flash stalls (RM0383 3.5), for up to 2 s per 128 KiB sector. */
#ifndef STM32F411_FLASH_STORE_H
#define STM32F411_FLASH_STORE_H

#include <stdint.h>

/* FLASH interface registers, RM0383 3.8 (base 0x4002_3C00). */
typedef struct {
    volatile uint32_t ACR, KEYR, OPTKEYR, SR, CR, OPTCR;
} flash_regs_t;
#define FLASH_REGS ((flash_regs_t *)0x40023C00u)

#define FLASH_KEY1 0x45670123u
#define FLASH_KEY2 0xCDEF89ABu
#define FLASH_SR_EOP (1u << 0)
#define FLASH_SR_OPERR (1u << 1)
#define FLASH_SR_WRPERR (1u << 4)
#define FLASH_SR_PGAERR (1u << 5)
#define FLASH_SR_PGPERR (1u << 6)
#define FLASH_SR_PGSERR (1u << 7)
#define FLASH_SR_BSY (1u << 16)
#define FLASH_SR_ERRORS \
    (FLASH_SR_OPERR | FLASH_SR_WRPERR | FLASH_SR_PGAERR | FLASH_SR_PGPERR | FLASH_SR_PGSERR)
#define FLASH_CR_PG (1u << 0)
#define FLASH_CR_SER (1u << 1)
#define FLASH_CR_SNB_SHIFT 3u
#define FLASH_CR_SNB_MASK (0xFu << 3)
#define FLASH_CR_PSIZE_X32 (2u << 8)
#define FLASH_CR_PSIZE_MASK (3u << 8)
#define FLASH_CR_STRT (1u << 16)
#define FLASH_CR_LOCK (1u << 31)
#define FLASH_OPTCR_BOR_LEV_SHIFT 2u /* brown-out level: 00 level 3 ... 11 off (RM0383 3.8.6) */
#define FLASH_OPTCR_BOR_LEV_MASK (3u << 2)
#define FLASH_ACR_ICRST (1u << 11)
#define FLASH_ACR_DCRST (1u << 12)
#define FLASH_ACR_ICEN_BIT (1u << 9)
#define FLASH_ACR_DCEN_BIT (1u << 10)

/* One erasable sector of the store: where it starts (bytes from the store's base), its size,
 * its SNB number and the bound on its erase. */
typedef struct {
    uint32_t offset, size, snb, erase_timeout_us;
} flash_sector_t;

/* Erase-time maxima at PSIZE x32, 2.7..3.6 V (the STM32F4 datasheets' "Flash memory
 * programming" table, tERASE16KB / tERASE64KB / tERASE128KB: 0.5 s / 1.1 s / 2 s); each wait
 * is bounded by twice that. A word programs in 100 us at most (tPROG). */
#define FLASH_ERASE64K_TIMEOUT_US 2200000u
#define FLASH_ERASE128K_TIMEOUT_US 4000000u
#define FLASH_WORD_TIMEOUT_US 1000u

/* RM0383 table 4: sectors 4 (64 KiB at 0x0801_0000) and 5-7 (128 KiB each). */
#define FLASH_STORE_ADDR 0x08010000u
#define FLASH_STORE_SIZE 0x70000u /* 458752 bytes */
#define FLASH_STORE_SECTORS 4u
extern const flash_sector_t flash_store_sectors[FLASH_STORE_SECTORS];

typedef struct {
    flash_regs_t *regs;
    volatile uint32_t *base;        /* the region, memory-mapped */
    uint32_t size;                  /* bytes */
    const flash_sector_t *sectors;  /* in address order, covering [0, size) exactly */
    uint32_t n_sectors;
    uint32_t (*now_us)(void);
    void (*before_erase)(void);     /* run before each sector's erase; may be NULL */
} flash_store_t;

/* Erase every sector that [offset, offset + len) touches (both multiples of 4, inside the
 * region; len 0 erases nothing), each checked to read 0xFF afterwards: a STAC_FLASH_* code.
 * Stops at the first sector that fails. */
int32_t flash_store_erase(const flash_store_t *f, uint32_t offset, uint32_t len);

/* Program len bytes at offset (both multiples of 4), word by word, each read back: a
 * STAC_FLASH_* code. */
int32_t flash_store_program(const flash_store_t *f, uint32_t offset, const uint8_t *data,
                            uint32_t len);

#endif /* STM32F411_FLASH_STORE_H */
