#include "flash_store.h"

#include <stdbool.h>
#include <stddef.h>

#include "stac_hal.h"

/* Wait until BSY clears (RM0383 3.5.3 step 5, 3.5.4 step 4), at most timeout_us. */
static int32_t wait_idle(const flash_store_t *f, uint32_t timeout_us) {
    const uint32_t t0 = f->now_us();
    while ((f->regs->SR & FLASH_SR_BSY) != 0u) {
        if (f->now_us() - t0 > timeout_us) {
            return STAC_FLASH_TIMEOUT;
        }
    }
    return (f->regs->SR & FLASH_SR_ERRORS) != 0u ? STAC_FLASH_FAILED : STAC_FLASH_OK;
}

/* RM0383 3.5.1: the key sequence unlocks FLASH_CR (a wrong sequence locks it until reset). */
static int32_t unlock(const flash_store_t *f) {
    const int32_t rc = wait_idle(f, FLASH_WORD_TIMEOUT_US);
    if (rc == STAC_FLASH_TIMEOUT) {
        return rc;
    }
    f->regs->SR = FLASH_SR_ERRORS | FLASH_SR_EOP; /* write 1 to clear leftovers */
    if ((f->regs->CR & FLASH_CR_LOCK) != 0u) {
        f->regs->KEYR = FLASH_KEY1;
        f->regs->KEYR = FLASH_KEY2;
    }
    return (f->regs->CR & FLASH_CR_LOCK) != 0u ? STAC_FLASH_FAILED : STAC_FLASH_OK;
}

/* End an operation: clear the mode bits, lock, and reset the ART caches (RM0383 3.4.2: a
 * cache reset needs the cache disabled) so that reads see the new contents. */
static void finish(const flash_store_t *f) {
    f->regs->CR &= ~(FLASH_CR_PG | FLASH_CR_SER | FLASH_CR_SNB_MASK);
    f->regs->CR |= FLASH_CR_LOCK;
    const uint32_t acr = f->regs->ACR;
    f->regs->ACR = acr & ~(FLASH_ACR_ICEN_BIT | FLASH_ACR_DCEN_BIT);
    f->regs->ACR = (acr & ~(FLASH_ACR_ICEN_BIT | FLASH_ACR_DCEN_BIT)) | FLASH_ACR_ICRST |
                   FLASH_ACR_DCRST;
    f->regs->ACR = acr & ~(FLASH_ACR_ICRST | FLASH_ACR_DCRST);
}

const flash_sector_t flash_store_sectors[FLASH_STORE_SECTORS] = {
    {0x00000u, 0x10000u, 4u, FLASH_ERASE64K_TIMEOUT_US},
    {0x10000u, 0x20000u, 5u, FLASH_ERASE128K_TIMEOUT_US},
    {0x30000u, 0x20000u, 6u, FLASH_ERASE128K_TIMEOUT_US},
    {0x50000u, 0x20000u, 7u, FLASH_ERASE128K_TIMEOUT_US},
};

static bool range_ok(const flash_store_t *f, uint32_t offset, uint32_t len) {
    return offset % 4u == 0u && len % 4u == 0u && offset <= f->size && len <= f->size - offset;
}

static bool reads_erased(const flash_store_t *f, const flash_sector_t *s) {
    for (uint32_t i = s->offset / 4u; i < (s->offset + s->size) / 4u; i++) {
        if (f->base[i] != 0xFFFFFFFFu) {
            return false;
        }
    }
    return true;
}

/* RM0383 3.5.3: SER and SNB, then STRT; PSIZE x32 sets the erase parallelism. */
static int32_t erase_sector(const flash_store_t *f, const flash_sector_t *s) {
    if (f->before_erase != NULL) {
        f->before_erase();
    }
    f->regs->CR = (f->regs->CR & ~(FLASH_CR_PSIZE_MASK | FLASH_CR_SNB_MASK | FLASH_CR_PG)) |
                  FLASH_CR_PSIZE_X32 | FLASH_CR_SER | (s->snb << FLASH_CR_SNB_SHIFT);
    f->regs->CR |= FLASH_CR_STRT;
    return wait_idle(f, s->erase_timeout_us);
}

int32_t flash_store_erase(const flash_store_t *f, uint32_t offset, uint32_t len) {
    if (!range_ok(f, offset, len)) {
        return STAC_FLASH_BAD_ARG;
    }
    if (len == 0u) {
        return STAC_FLASH_OK;
    }
    int32_t rc = unlock(f);
    if (rc != STAC_FLASH_OK) {
        return rc;
    }
    uint32_t first = f->n_sectors, end = 0u; /* the sectors [first, end) the range touches */
    for (uint32_t k = 0u; k < f->n_sectors; k++) {
        const flash_sector_t *s = &f->sectors[k];
        if (offset < s->offset + s->size && offset + len > s->offset) {
            first = k < first ? k : first;
            end = k + 1u;
        }
    }
    for (uint32_t k = first; k < end && rc == STAC_FLASH_OK; k++) {
        rc = erase_sector(f, &f->sectors[k]);
    }
    finish(f);
    for (uint32_t k = first; k < end && rc == STAC_FLASH_OK; k++) {
        if (!reads_erased(f, &f->sectors[k])) {
            rc = STAC_FLASH_FAILED;
        }
    }
    return rc;
}

int32_t flash_store_program(const flash_store_t *f, uint32_t offset, const uint8_t *data,
                            uint32_t len) {
    if (!range_ok(f, offset, len)) {
        return STAC_FLASH_BAD_ARG;
    }
    int32_t rc = unlock(f);
    if (rc != STAC_FLASH_OK) {
        return rc;
    }
    /* RM0383 3.5.4: PG with PSIZE x32, then one 32-bit write per word, BSY between words. */
    f->regs->CR = (f->regs->CR & ~(FLASH_CR_PSIZE_MASK | FLASH_CR_SER | FLASH_CR_SNB_MASK)) |
                  FLASH_CR_PSIZE_X32 | FLASH_CR_PG;
    for (uint32_t i = 0u; i < len && rc == STAC_FLASH_OK; i += 4u) {
        const uint32_t word = (uint32_t)data[i] | ((uint32_t)data[i + 1u] << 8) |
                              ((uint32_t)data[i + 2u] << 16) | ((uint32_t)data[i + 3u] << 24);
        volatile uint32_t *dst = &f->base[(offset + i) / 4u];
        *dst = word;
        rc = wait_idle(f, FLASH_WORD_TIMEOUT_US);
        if (rc == STAC_FLASH_OK && *dst != word) {
            rc = STAC_FLASH_FAILED; /* e.g. a bit that was not erased */
        }
    }
    finish(f);
    return rc;
}
