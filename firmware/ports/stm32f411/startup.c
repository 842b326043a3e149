/* Reset and exception entry: vector table, the ROM bootloader on request, memory
 * initialisation, and the fault record every fault and unexpected interrupt leaves before the
 * reset (boot_record.h), which the next boot reports. */
#include <stdint.h>

#include "boot_record.h"
#include "regs.h"

extern uint32_t _sidata, _sdata, _edata, _sbss, _ebss, _estack;
extern volatile uint32_t g_probe_active, g_probe_faulted;

int main(void);
void Reset_Handler(void);
void Default_Handler(void);
void HardFault_Handler(void);
void fault_from_frame(uint32_t *frame);
/* The host link's interrupt: each build links one of them (host_link.h); the other stays the
 * default handler, and its interrupt is never enabled. */
void USART1_IRQHandler(void) __attribute__((weak, alias("Default_Handler")));
void OTG_FS_IRQHandler(void) __attribute__((weak, alias("Default_Handler")));

#define IRQ_COUNT 86u
#define USART1_SLOT (16u + USART1_IRQN)
#define OTG_FS_SLOT (16u + OTG_FS_IRQN)
_Static_assert(sizeof(boot_record_t) <= 256u, "the record fits the linker's NOINIT region");

/* Runs of default handlers for the vector table (positional: designators that override a
 * default would need a GNU extension or trip -Woverride-init). */
#define D Default_Handler
#define D2 D, D
#define D4 D2, D2
#define D8 D4, D4
#define D16 D8, D8
_Static_assert(USART1_SLOT == 53u && OTG_FS_SLOT == 83u, "the table below places them so");

/* Cortex-M4 vector table: 16 system entries, then the STM32F411's 86 interrupts. Every entry
 * without a handler of its own is the default handler: an unexpected interrupt is recorded
 * and resets, never jumps to 0. */
__attribute__((section(".isr_vector"), used))
static void (*const k_vectors[16u + IRQ_COUNT])(void) = {
    (void (*)(void))(uintptr_t)&_estack,
    Reset_Handler,
    D,                 /* NMI */
    HardFault_Handler,
    HardFault_Handler, /* MemManage (disabled: escalates) */
    HardFault_Handler, /* BusFault */
    HardFault_Handler, /* UsageFault */
    D4, D4, D,         /* 7-15: reserved, SVCall, DebugMon, reserved, PendSV, SysTick */
    D16, D16, D4, D,   /* IRQ 0-36 */
    USART1_IRQHandler, /* IRQ 37 */
    D16, D8, D4, D,    /* IRQ 38-66 */
    OTG_FS_IRQHandler, /* IRQ 67 */
    D16, D2,           /* IRQ 68-85 */
};
#undef D

/* ENTER_BOOTLOADER left the magic and reset: the peripherals, clocks and watchdog are as the
 * reset left them, which is what the ROM bootloader expects. Map the system memory at 0, take
 * its stack pointer and reset vector, and go. Under QEMU, whose board has no system memory,
 * the load faults and the fault record shows the attempt (tests/firmware/test_qemu_faults.py). */
__attribute__((noreturn, noinline)) static void start_rom_bootloader(void) {
    g_probe_active = 0u; /* .bss is not initialised yet: a fault here is a real one */
    RCC->APB2ENR |= RCC_APB2ENR_SYSCFG;
    (void)RCC->APB2ENR;
    SYSCFG_MEMRM = SYSCFG_MEMRM_MEM_MODE_SYSTEM;
    const volatile uint32_t *rom = (const volatile uint32_t *)SYSTEM_MEMORY_BASE;
    const uint32_t sp = rom[0];
    const uint32_t entry = rom[1];
    __asm volatile("msr msp, %0\n"
                   "bx %1\n" ::"r"(sp),
                   "r"(entry)
                   : "memory");
    __builtin_unreachable();
}

void Reset_Handler(void) {
    if (g_boot_record.dfu_magic == BOOT_DFU_MAGIC) {
        g_boot_record.dfu_magic = 0u; /* once: a reset in the bootloader comes back here */
        start_rom_bootloader();
    }
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

/* Find the exception frame (main or process stack) and hand it to C: every fault and every
 * interrupt nobody expects ends in fault_from_frame. */
__attribute__((naked)) void HardFault_Handler(void) {
    __asm volatile(
        "tst lr, #4\n"
        "ite eq\n"
        "mrseq r0, msp\n"
        "mrsne r0, psp\n"
        "b fault_from_frame\n");
}

__attribute__((naked)) void Default_Handler(void) {
    __asm volatile(
        "tst lr, #4\n"
        "ite eq\n"
        "mrseq r0, msp\n"
        "mrsne r0, psp\n"
        "b fault_from_frame\n");
}

/* A load inside a probe (uid.c) may fault on a part or model without that memory: skip the
 * instruction and let the probe see the flag. Anything else is recorded for the next boot
 * (stacked PC/LR/xPSR, the fault status and address registers) and resets the device. */
void fault_from_frame(uint32_t *frame) {
    uint32_t ipsr;
    __asm volatile("mrs %0, ipsr" : "=r"(ipsr));
    if (g_probe_active != 0u && ipsr == 3u) {
        g_probe_faulted = 1u;
        const uint16_t insn = *(const uint16_t *)(uintptr_t)frame[6];
        frame[6] += (insn >> 11) >= 0x1Du ? 4u : 2u; /* 32-bit Thumb-2 encodings */
        SCB_CFSR = SCB_CFSR;                      /* write-one-to-clear */
        SCB_HFSR = SCB_HFSR;
        return;
    }
    boot_record_fault(&g_boot_record, frame, ipsr, SCB_CFSR, SCB_HFSR, SCB_MMFAR, SCB_BFAR);
    __asm volatile("dsb" ::: "memory");
    SCB_AIRCR = SCB_AIRCR_RESET;
    for (;;) {
    }
}
