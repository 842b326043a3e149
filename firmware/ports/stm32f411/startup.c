/* Reset and exception entry: vector table, memory initialisation, fault handling. */
#include <stdint.h>

#include "regs.h"

extern uint32_t _sidata, _sdata, _edata, _sbss, _ebss, _estack;
extern volatile uint32_t g_probe_active, g_probe_faulted;

int main(void);
void Reset_Handler(void);
void Default_Handler(void);
void HardFault_Handler(void);
void fault_from_frame(uint32_t *frame);
void SysTick_Handler(void);
/* The host link's interrupt: each build links one of them (host_link.h); the other stays the
 * default handler, and its interrupt is never enabled. */
void USART1_IRQHandler(void) __attribute__((weak, alias("Default_Handler")));
void OTG_FS_IRQHandler(void) __attribute__((weak, alias("Default_Handler")));

#define IRQ_COUNT 86u
#define USART1_SLOT (16u + USART1_IRQN)
#define OTG_FS_SLOT (16u + OTG_FS_IRQN)

/* Cortex-M4 vector table: 16 system entries, then the STM32F411's 86 interrupts. */
__attribute__((section(".isr_vector"), used))
static void (*const k_vectors[16u + IRQ_COUNT])(void) = {
    [0] = (void (*)(void))(uintptr_t)&_estack,
    [1] = Reset_Handler,
    [2] = Default_Handler,   /* NMI */
    [3] = HardFault_Handler,
    [4] = HardFault_Handler, /* MemManage (disabled: escalates) */
    [5] = HardFault_Handler, /* BusFault */
    [6] = HardFault_Handler, /* UsageFault */
    [11] = Default_Handler,  /* SVCall */
    [12] = Default_Handler,  /* DebugMon */
    [14] = Default_Handler,  /* PendSV */
    [15] = SysTick_Handler,
    [USART1_SLOT] = USART1_IRQHandler,
    [OTG_FS_SLOT] = OTG_FS_IRQHandler,
};

void Reset_Handler(void) {
    /* The FPU must be on before any code the compiler may give float instructions. */
    SCB_CPACR |= SCB_CPACR_CP10_CP11_FULL;
    __asm volatile("dsb\n isb" ::: "memory");
    uint32_t *src = &_sidata;
    for (uint32_t *dst = &_sdata; dst < &_edata;) {
        *dst++ = *src++;
    }
    for (uint32_t *dst = &_sbss; dst < &_ebss;) {
        *dst++ = 0u;
    }
    (void)main();
    /* main never returns; if it did, start over rather than sit here. */
    SCB_AIRCR = SCB_AIRCR_RESET;
    for (;;) {
    }
}

/* Any unexpected interrupt: reset, which is recoverable; hanging here is not. */
void Default_Handler(void) {
    SCB_AIRCR = SCB_AIRCR_RESET;
    for (;;) {
    }
}

/* Find the exception frame (main or process stack) and hand it to C. */
__attribute__((naked)) void HardFault_Handler(void) {
    __asm volatile(
        "tst lr, #4\n"
        "ite eq\n"
        "mrseq r0, msp\n"
        "mrsne r0, psp\n"
        "b fault_from_frame\n");
}

/* A load inside a probe (uid.c) may fault on a part or model without that memory: skip the
 * instruction and let the probe see the flag. Everything else resets the device. */
void fault_from_frame(uint32_t *frame) {
    if (g_probe_active != 0u) {
        g_probe_faulted = 1u;
        const uint16_t insn = *(const uint16_t *)(uintptr_t)frame[6];
        frame[6] += (insn >> 11) >= 0x1Du ? 4u : 2u; /* 32-bit Thumb-2 encodings */
        SCB_CFSR = SCB_CFSR;                      /* write-one-to-clear */
        SCB_HFSR = SCB_HFSR;
        return;
    }
    SCB_AIRCR = SCB_AIRCR_RESET;
    for (;;) {
    }
}
