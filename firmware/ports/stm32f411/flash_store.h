/* The model store in the STM32F411's flash: sector 7, the last 128 KiB (0x0806_0000 ..
 * 0x0807_FFFF), which the linker script keeps free of code and data.
 *
 * Register sequences from RM0383 (STM32F411xC/E reference manual) section 3 "Embedded Flash
 * memory interface": 3.5.1 unlocking (FLASH_KEYR keys), 3.5.3 sector erase (SER, SNB, STRT),
 * 3.5.4 programming (PG, PSIZE x32 for a 2.7..3.6 V supply), 3.7 error flags, 3.8 register map;
 * 3.4.2 (ART accelerator) for resetting the caches after the contents changed.
 *
 * The register block and the mapped sector are parameters so that the native C tests can run
 * the same code against a fake block (tests/firmware/c/test_flash_store.c); the port passes
 * FLASH_REGS and the sector's address. Every wait is bounded by a timeout read from now_us.
 * While the flash erases or programs, a CPU fetching code from flash stalls (RM0383 3.5):
 * main.c lengthens the watchdog around the erase (up to 2 s for 128 KiB, datasheet). */
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
#define FLASH_ACR_ICRST (1u << 11)
#define FLASH_ACR_DCRST (1u << 12)
#define FLASH_ACR_ICEN_BIT (1u << 9)
#define FLASH_ACR_DCEN_BIT (1u << 10)

#define FLASH_STORE_SECTOR 7u
#define FLASH_STORE_ADDR 0x08060000u
#define FLASH_STORE_SIZE 0x20000u
/* Bounds: sector erase 128 KiB at x32 is 2 s at most, a word 100 us (DS10314 table 47). */
#define FLASH_ERASE_TIMEOUT_US 4000000u
#define FLASH_WORD_TIMEOUT_US 1000u

typedef struct {
    flash_regs_t *regs;
    volatile uint32_t *base; /* the sector, memory-mapped */
    uint32_t size;           /* bytes */
    uint32_t sector;         /* SNB */
    uint32_t (*now_us)(void);
} flash_store_t;

/* Erase the sector: a STAC_FLASH_* code. */
int32_t flash_store_erase(const flash_store_t *f);

/* Program len bytes at offset (both multiples of 4), word by word, each read back: a
 * STAC_FLASH_* code. */
int32_t flash_store_program(const flash_store_t *f, uint32_t offset, const uint8_t *data,
                            uint32_t len);

#endif /* STM32F411_FLASH_STORE_H */
