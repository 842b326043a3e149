/* Model check on a Cortex-M4F under QEMU (-M netduinoplus2): the model image sits in flash at
 * MC_IMAGE_ADDR (QEMU's generic loader puts it there; the STM32F405 QEMU models has 1 MiB of
 * flash, the check itself links into the F411's first 512 KiB), input and output records
 * are files opened through semihosting, SysTick stamps every stac_model_push, and the exit
 * code leaves through SYS_EXIT_EXTENDED (the shared harness, ../qemu_harness/semihost.h). Built
 * by the PlatformIO env `model_check`. */
#include <stdint.h>

#include "model_check.h"
#include "semihost.h"

#define MC_IMAGE_ADDR 0x08080000u
#define MC_IMAGE_REGION 0x80000u

static uint32_t g_in, g_out;

uint32_t mc_read(uint8_t *buf, uint32_t n) {
    return n - sh_read(g_in, buf, n); /* the call returns the bytes NOT read */
}

void mc_write(const uint8_t *buf, uint32_t n) { sh_write(g_out, buf, n); }

uint32_t mc_ticks(void) { return SYST_CVR; }

uint32_t mc_calibrate(uint32_t iterations) { return systick_spin(iterations); }

int main(void) {
    systick_start();
    static const char in_name[] = "model_check.in", out_name[] = "model_check.out";
    g_in = sh_open(in_name, sizeof in_name - 1u, SH_OPEN_RB);
    g_out = sh_open(out_name, sizeof out_name - 1u, SH_OPEN_WB);
    if (g_in == SH_BAD_HANDLE || g_out == SH_BAD_HANDLE) return 1;
    const uint8_t *image = (const uint8_t *)MC_IMAGE_ADDR;
    uint32_t size = (uint32_t)image[12] | ((uint32_t)image[13] << 8) |
                    ((uint32_t)image[14] << 16) | ((uint32_t)image[15] << 24);
    if (size > MC_IMAGE_REGION) size = 0u;
    const int rc = mc_run(image, size);
    sh_close(g_out);
    return rc;
}
