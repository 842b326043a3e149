/* Model check on a Cortex-M4F under QEMU (-M netduinoplus2): the model image sits in flash at
 * MC_IMAGE_ADDR (QEMU's generic loader puts it there; the STM32F405 QEMU models has 1 MiB of
 * flash, the check itself links into the F411's first 512 KiB), input and output records
 * are files opened through semihosting, SysTick stamps every stac_model_push, and the exit
 * code leaves through SYS_EXIT_EXTENDED. Built by the PlatformIO env `model_check`. */
#include <stdint.h>

#include "model_check.h"

#define MC_IMAGE_ADDR 0x08080000u
#define MC_IMAGE_REGION 0x80000u

#define SYS_OPEN 0x01u
#define SYS_CLOSE 0x02u
#define SYS_WRITE 0x05u
#define SYS_READ 0x06u
#define SYS_EXIT_EXTENDED 0x20u
#define ADP_STOPPED_APPLICATION_EXIT 0x20026u
#define OPEN_RB 1u
#define OPEN_WB 5u

#define SCB_CPACR (*(volatile uint32_t *)0xE000ED88u)
#define SYST_CSR (*(volatile uint32_t *)0xE000E010u)
#define SYST_RVR (*(volatile uint32_t *)0xE000E014u)
#define SYST_CVR (*(volatile uint32_t *)0xE000E018u)
#define SYST_ENABLE_CPUCLK 0x5u

extern uint32_t _sidata, _sdata, _edata, _sbss, _ebss, _estack;
int main(void);
void Reset_Handler(void);
void Fault_Handler(void);

__attribute__((section(".isr_vector"), used)) static void (*const k_vectors[16])(void) = {
    [0] = (void (*)(void))(uintptr_t)&_estack,
    [1] = Reset_Handler,
    [2] = Fault_Handler,
    [3] = Fault_Handler,
    [4] = Fault_Handler,
    [5] = Fault_Handler,
    [6] = Fault_Handler,
    [11] = Fault_Handler,
    [12] = Fault_Handler,
    [14] = Fault_Handler,
    [15] = Fault_Handler,
};

static uint32_t semihost(uint32_t op, const void *arg) {
    register uint32_t r0 __asm("r0") = op;
    register const void *r1 __asm("r1") = arg;
    __asm volatile("bkpt 0xAB" : "+r"(r0) : "r"(r1) : "memory");
    return r0;
}

static __attribute__((noreturn)) void semihost_exit(uint32_t code) {
    const uint32_t args[2] = {ADP_STOPPED_APPLICATION_EXIT, code};
    for (;;) (void)semihost(SYS_EXIT_EXTENDED, args);
}

void Fault_Handler(void) { semihost_exit(3u); }

void Reset_Handler(void) {
    SCB_CPACR |= 0xFu << 20; /* the FPU on before any float instruction */
    __asm volatile("dsb\n isb" ::: "memory");
    uint32_t *src = &_sidata;
    for (uint32_t *dst = &_sdata; dst < &_edata;) *dst++ = *src++;
    for (uint32_t *dst = &_sbss; dst < &_ebss;) *dst++ = 0u;
    semihost_exit((uint32_t)main());
}

static uint32_t g_in, g_out;

static uint32_t open_file(const char *name, uint32_t len, uint32_t mode) {
    const uint32_t args[3] = {(uint32_t)(uintptr_t)name, mode, len};
    return semihost(SYS_OPEN, args);
}

uint32_t mc_read(uint8_t *buf, uint32_t n) {
    const uint32_t args[3] = {g_in, (uint32_t)(uintptr_t)buf, n};
    return n - semihost(SYS_READ, args); /* the call returns the bytes NOT read */
}

void mc_write(const uint8_t *buf, uint32_t n) {
    const uint32_t args[3] = {g_out, (uint32_t)(uintptr_t)buf, n};
    if (semihost(SYS_WRITE, args) != 0u) semihost_exit(4u);
}

uint32_t mc_ticks(void) { return SYST_CVR; }

uint32_t mc_calibrate(uint32_t iterations) {
    const uint32_t t0 = SYST_CVR;
    uint32_t n = iterations;
    __asm volatile("1: subs %0, %0, #1\n bne 1b" : "+r"(n) : : "cc");
    return (t0 - SYST_CVR) & 0xFFFFFFu;
}

int main(void) {
    SYST_RVR = 0xFFFFFFu;
    SYST_CVR = 0u;
    SYST_CSR = SYST_ENABLE_CPUCLK;
    static const char in_name[] = "model_check.in", out_name[] = "model_check.out";
    g_in = open_file(in_name, sizeof in_name - 1u, OPEN_RB);
    g_out = open_file(out_name, sizeof out_name - 1u, OPEN_WB);
    if (g_in == 0xFFFFFFFFu || g_out == 0xFFFFFFFFu) return 1;
    const uint8_t *image = (const uint8_t *)MC_IMAGE_ADDR;
    uint32_t size = (uint32_t)image[12] | ((uint32_t)image[13] << 8) |
                    ((uint32_t)image[14] << 16) | ((uint32_t)image[15] << 24);
    if (size > MC_IMAGE_REGION) size = 0u;
    const int rc = mc_run(image, size);
    const uint32_t args[1] = {g_out};
    (void)semihost(SYS_CLOSE, args);
    return rc;
}
