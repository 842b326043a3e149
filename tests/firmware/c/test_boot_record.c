/* The STM32 port's boot record (ports/stm32f411/boot_record.c): the reset flags and the .noinit
 * record a fault handler left become the core's boot report; abnormal resets are counted in a
 * row and three of them mean safe mode; a power-on's noise is never taken for a record. */
#include <string.h>

#include "boot_record.h"
#include "check.h"

#define PIN (1u << 26)
#define POR (1u << 27)
#define BOR (1u << 25)
#define SFT (1u << 28)
#define IWDG (1u << 29)
#define OPTCR_BOR_OFF 0x0FFFAAEDu /* the factory value: BOR_LEV = 11 */
#define OPTCR_BOR_3 0x0FFFAAE1u

static boot_record_t g_r;

static void fault_now(uint32_t pc) {
    const uint32_t frame[8] = {1u, 2u, 3u, 4u, 12u, 0x08000F13u, pc, 0x61000000u};
    boot_record_fault(&g_r, frame, 3u, 0x00010000u, 0x40000000u, 0xE000EDF4u, 0xE000EDF8u);
}

TEST(boot_record_power_on_noise_is_not_a_record) {
    memset(&g_r, 0xA5, sizeof g_r);
    g_r.fault_magic = BOOT_FAULT_MAGIC; /* even noise that looks like one */
    stac_boot_t b;
    boot_record_take(&g_r, POR | BOR | PIN, OPTCR_BOR_OFF, &b);
    CHECK_EQ(b.reset_cause, STAC_RESET_POWER | STAC_RESET_PIN); /* BOR flag of a power-on */
    CHECK_EQ(b.fault_pc, 0u);
    CHECK_EQ(b.abnormal_resets, 0);
    CHECK_EQ(b.safe_mode, 0);
    CHECK_EQ(b.bor_level, 0);
}

TEST(boot_record_fault_reported_once) {
    stac_boot_t b;
    boot_record_take(&g_r, POR | PIN, OPTCR_BOR_3, &b);
    fault_now(0x08001A2Cu);
    boot_record_take(&g_r, SFT | PIN, OPTCR_BOR_3, &b);
    CHECK_EQ(b.reset_cause, STAC_RESET_SOFTWARE | STAC_RESET_PIN | STAC_RESET_FAULT);
    CHECK_EQ(b.fault_pc, 0x08001A2Cu);
    CHECK_EQ(b.fault_lr, 0x08000F13u);
    CHECK_EQ(b.fault_xpsr, 0x61000003u); /* flags kept, the exception number the handler's */
    CHECK_EQ(b.fault_cfsr, 0x00010000u);
    CHECK_EQ(b.fault_hfsr, 0x40000000u);
    CHECK_EQ(b.fault_mmfar, 0xE000EDF4u);
    CHECK_EQ(b.fault_bfar, 0xE000EDF8u);
    CHECK_EQ(b.abnormal_resets, 1);
    CHECK_EQ(b.bor_level, 3);
    boot_record_take(&g_r, PIN, OPTCR_BOR_3, &b); /* the next reset: a button press */
    CHECK_EQ(b.reset_cause, STAC_RESET_PIN);
    CHECK_EQ(b.fault_pc, 0u);
    CHECK_EQ(b.abnormal_resets, 0);
}

TEST(boot_record_three_abnormal_resets_mean_safe_mode) {
    stac_boot_t b;
    boot_record_take(&g_r, POR | PIN, OPTCR_BOR_3, &b);
    boot_record_take(&g_r, IWDG | PIN, OPTCR_BOR_3, &b);
    CHECK_EQ(b.abnormal_resets, 1);
    CHECK_EQ(b.safe_mode, 0);
    fault_now(0x08002000u);
    boot_record_take(&g_r, SFT | PIN, OPTCR_BOR_3, &b);
    CHECK_EQ(b.abnormal_resets, 2);
    CHECK_EQ(b.safe_mode, 0);
    boot_record_take(&g_r, BOR | PIN, OPTCR_BOR_3, &b); /* a brown-out: BORRSTF without POR */
    CHECK_EQ(b.reset_cause, STAC_RESET_BROWNOUT | STAC_RESET_PIN);
    CHECK_EQ(b.abnormal_resets, 3);
    CHECK_EQ(b.safe_mode, 1);
    boot_record_take(&g_r, IWDG | PIN, OPTCR_BOR_3, &b);
    CHECK_EQ(b.safe_mode, 1);
    boot_record_take(&g_r, SFT | PIN, OPTCR_BOR_3, &b); /* e.g. after ENTER_BOOTLOADER: normal */
    CHECK_EQ(b.abnormal_resets, 0);
    CHECK_EQ(b.safe_mode, 0);
}

TEST(boot_record_bor_levels) {
    CHECK_EQ(boot_bor_level(0u << 2), 3);
    CHECK_EQ(boot_bor_level(1u << 2), 2);
    CHECK_EQ(boot_bor_level(2u << 2), 1);
    CHECK_EQ(boot_bor_level(3u << 2), 0);
    CHECK_EQ(boot_bor_level(OPTCR_BOR_OFF), 0);
}

const test_case_t g_boot_record_tests[] = {
    {"boot_record_power_on_noise_is_not_a_record", boot_record_power_on_noise_is_not_a_record},
    {"boot_record_fault_reported_once", boot_record_fault_reported_once},
    {"boot_record_three_abnormal_resets_mean_safe_mode",
     boot_record_three_abnormal_resets_mean_safe_mode},
    {"boot_record_bor_levels", boot_record_bor_levels},
    {NULL, NULL},
};
