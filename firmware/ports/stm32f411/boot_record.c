#include "boot_record.h"

#include <string.h>

/* Flag bits of RCC_CSR (RM0383 §6.3.21); regs.h names the same bits for the port. Kept here as
 * plain numbers so that the native tests need no register header. */
#define CSR_BORRSTF (1u << 25)
#define CSR_PINRSTF (1u << 26)
#define CSR_PORRSTF (1u << 27)
#define CSR_SFTRSTF (1u << 28)
#define CSR_IWDGRSTF (1u << 29)
#define CSR_WWDGRSTF (1u << 30)
#define CSR_LPWRRSTF (1u << 31)
#define OPTCR_BOR_LEV_SHIFT 2u

void boot_record_fault(boot_record_t *r, const uint32_t *frame, uint32_t ipsr, uint32_t cfsr,
                       uint32_t hfsr, uint32_t mmfar, uint32_t bfar) {
    r->lr = frame[5];
    r->pc = frame[6];
    r->xpsr = (frame[7] & ~0x1FFu) | (ipsr & 0x1FFu);
    r->cfsr = cfsr;
    r->hfsr = hfsr;
    r->mmfar = mmfar;
    r->bfar = bfar;
    r->fault_magic = BOOT_FAULT_MAGIC; /* last: a record torn by a second fault is not used */
}

uint8_t boot_bor_level(uint32_t optcr) {
    return (uint8_t)(3u - ((optcr >> OPTCR_BOR_LEV_SHIFT) & 3u));
}

uint8_t boot_reset_cause(uint32_t csr) {
    uint8_t c = 0u;
    c |= (csr & CSR_PINRSTF) != 0u ? STAC_RESET_PIN : 0u;
    c |= (csr & CSR_PORRSTF) != 0u ? STAC_RESET_POWER : 0u;
    c |= (csr & CSR_BORRSTF) != 0u && (csr & CSR_PORRSTF) == 0u ? STAC_RESET_BROWNOUT : 0u;
    c |= (csr & CSR_SFTRSTF) != 0u ? STAC_RESET_SOFTWARE : 0u;
    c |= (csr & CSR_IWDGRSTF) != 0u ? STAC_RESET_IWDG : 0u;
    c |= (csr & CSR_WWDGRSTF) != 0u ? STAC_RESET_WWDG : 0u;
    c |= (csr & CSR_LPWRRSTF) != 0u ? STAC_RESET_LOW_POWER : 0u;
    return c;
}

void boot_record_take(boot_record_t *r, uint32_t csr, uint32_t optcr, stac_boot_t *out) {
    memset(out, 0, sizeof *out);
    out->reset_cause = boot_reset_cause(csr);
    out->bor_level = boot_bor_level(optcr);
    const int power_on = (csr & CSR_PORRSTF) != 0u;
    if (!power_on && r->fault_magic == BOOT_FAULT_MAGIC) {
        out->reset_cause |= STAC_RESET_FAULT;
        out->fault_pc = r->pc;
        out->fault_lr = r->lr;
        out->fault_xpsr = r->xpsr;
        out->fault_cfsr = r->cfsr;
        out->fault_hfsr = r->hfsr;
        out->fault_mmfar = r->mmfar;
        out->fault_bfar = r->bfar;
    }
    r->fault_magic = 0u; /* reported once */
    const uint8_t abnormal_bits =
        STAC_RESET_FAULT | STAC_RESET_IWDG | STAC_RESET_WWDG | STAC_RESET_BROWNOUT;
    uint32_t n = (!power_on && r->abnormal_check == ~r->abnormal) ? r->abnormal : 0u;
    n = (out->reset_cause & abnormal_bits) != 0u ? (n < 255u ? n + 1u : 255u) : 0u;
    r->abnormal = n;
    r->abnormal_check = ~n;
    out->abnormal_resets = (uint8_t)n;
    out->safe_mode = n >= STAC_SAFE_MODE_AFTER ? 1u : 0u;
}
