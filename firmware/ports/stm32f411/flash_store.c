#include "flash_store.h"

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

int32_t flash_store_erase(const flash_store_t *f) {
    int32_t rc = unlock(f);
    if (rc != STAC_FLASH_OK) {
        return rc;
    }
    /* RM0383 3.5.3: SER and SNB, then STRT; PSIZE x32 sets the erase parallelism. */
    f->regs->CR = (f->regs->CR & ~(FLASH_CR_PSIZE_MASK | FLASH_CR_SNB_MASK | FLASH_CR_PG)) |
                  FLASH_CR_PSIZE_X32 | FLASH_CR_SER | (f->sector << FLASH_CR_SNB_SHIFT);
    f->regs->CR |= FLASH_CR_STRT;
    rc = wait_idle(f, FLASH_ERASE_TIMEOUT_US);
    finish(f);
    if (rc == STAC_FLASH_OK) {
        for (uint32_t i = 0u; i < f->size / 4u; i++) {
            if (f->base[i] != 0xFFFFFFFFu) {
                return STAC_FLASH_FAILED;
            }
        }
    }
    return rc;
}

int32_t flash_store_program(const flash_store_t *f, uint32_t offset, const uint8_t *data,
                            uint32_t len) {
    if (offset % 4u != 0u || len % 4u != 0u || offset > f->size || len > f->size - offset) {
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
