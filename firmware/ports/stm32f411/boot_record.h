/* What survives a reset in RAM the start-up code never initialises (.noinit: the first 256 bytes
 * of SRAM, outside every section of the image, stm32f411ce.ld): the fault record the fault
 * handlers write, the count of abnormal resets in a row, and the request to start the ROM
 * bootloader. After a power-on the region holds noise, so each part carries a check word.
 *
 * boot_record_take() turns it and the reset flags (RCC_CSR) into the core's stac_boot_t at
 * boot. It works on values and a pointer only, so the native C tests run it
 * (tests/firmware/c/test_boot_record.c). */
#ifndef STM32F411_BOOT_RECORD_H
#define STM32F411_BOOT_RECORD_H

#include <stdint.h>

#include "stac_state.h"

#define BOOT_FAULT_MAGIC 0xFA017EC0u /* a fault record is present */
#define BOOT_DFU_MAGIC 0xDF0B007Cu   /* ENTER_BOOTLOADER: jump to the ROM at the next reset */

typedef struct {
    uint32_t fault_magic; /* BOOT_FAULT_MAGIC when the fields below hold a fault */
    uint32_t pc, lr, xpsr, cfsr, hfsr, mmfar, bfar;
    uint32_t abnormal;       /* abnormal resets in a row */
    uint32_t abnormal_check; /* ~abnormal; anything else: noise after a power-on */
    uint32_t dfu_magic;      /* BOOT_DFU_MAGIC: start the ROM bootloader */
} boot_record_t;

/* The region the linker script reserves (stm32f411ce.ld, NOINIT). */
extern boot_record_t g_boot_record;

/* The fault handlers: keep the stacked frame (r0-r3, r12, lr, pc, xpsr) and the fault status
 * registers. xpsr keeps the stacked flags with its exception number replaced by the handler's
 * own (ipsr): 3 HardFault, 16 + n interrupt n. */
void boot_record_fault(boot_record_t *r, const uint32_t *frame, uint32_t ipsr, uint32_t cfsr,
                       uint32_t hfsr, uint32_t mmfar, uint32_t bfar);

/* At boot: the reset flags (RCC_CSR before RMVF clears them) and the option bytes' FLASH_OPTCR
 * give the report; the fault record is consumed (reported once), the abnormal count updated
 * (reset by a power-on or a normal reset). */
void boot_record_take(boot_record_t *r, uint32_t rcc_csr, uint32_t optcr, stac_boot_t *out);

/* FLASH_OPTCR's BOR_LEV as a level: 00 level 3, 01 level 2, 10 level 1, 11 off (0). */
uint8_t boot_bor_level(uint32_t optcr);

/* RCC_CSR's flags as STAC_RESET_* bits (a brown-out only without a power-on: the F411 sets
 * BORRSTF on every power-on too). */
uint8_t boot_reset_cause(uint32_t rcc_csr);

#endif /* STM32F411_BOOT_RECORD_H */
