/* See semihost.h. Linked into each QEMU program by its PlatformIO env (platformio.ini). */
#include "semihost.h"

#define SYS_OPEN 0x01u
#define SYS_CLOSE 0x02u
#define SYS_WRITE 0x05u
#define SYS_READ 0x06u
#define SYS_EXIT_EXTENDED 0x20u
#define ADP_STOPPED_APPLICATION_EXIT 0x20026u

#define SCB_CPACR (*(volatile uint32_t *)0xE000ED88u)
#define SYST_CSR (*(volatile uint32_t *)0xE000E010u)
#define SYST_RVR (*(volatile uint32_t *)0xE000E014u)
#define SYST_ENABLE_CPUCLK 0x5u

extern uint32_t _sidata, _sdata, _edata, _sbss, _ebss, _estack;
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

void sh_exit(uint32_t code) {
    const uint32_t args[2] = {ADP_STOPPED_APPLICATION_EXIT, code};
    for (;;) (void)semihost(SYS_EXIT_EXTENDED, args);
}

void Fault_Handler(void) { sh_exit(3u); }

void Reset_Handler(void) {
    SCB_CPACR |= 0xFu << 20; /* the FPU on before any float instruction */
    __asm volatile("dsb\n isb" ::: "memory");
    uint32_t *src = &_sidata;
    for (uint32_t *dst = &_sdata; dst < &_edata;) *dst++ = *src++;
    for (uint32_t *dst = &_sbss; dst < &_ebss;) *dst++ = 0u;
    sh_exit((uint32_t)main());
}

uint32_t sh_open(const char *name, uint32_t len, uint32_t mode) {
    const uint32_t args[3] = {(uint32_t)(uintptr_t)name, mode, len};
    return semihost(SYS_OPEN, args);
}

uint32_t sh_read(uint32_t handle, void *buf, uint32_t n) {
    const uint32_t args[3] = {handle, (uint32_t)(uintptr_t)buf, n};
    return semihost(SYS_READ, args);
}

void sh_write(uint32_t handle, const void *buf, uint32_t n) {
    const uint32_t args[3] = {handle, (uint32_t)(uintptr_t)buf, n};
    if (semihost(SYS_WRITE, args) != 0u) sh_exit(4u);
}

void sh_close(uint32_t handle) {
    const uint32_t args[1] = {handle};
    (void)semihost(SYS_CLOSE, args);
}

void systick_start(void) {
    SYST_RVR = SYST_MASK;
    SYST_CVR = 0u;
    SYST_CSR = SYST_ENABLE_CPUCLK;
}

uint32_t systick_spin(uint32_t iterations) {
    const uint32_t t0 = SYST_CVR;
    uint32_t n = iterations;
    __asm volatile("1: subs %0, %0, #1\n bne 1b" : "+r"(n) : : "cc");
    return (t0 - SYST_CVR) & SYST_MASK;
}
