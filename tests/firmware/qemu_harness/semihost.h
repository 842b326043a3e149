/* The bare-metal harness the QEMU programs share (tests/firmware/model_check, timeline): a
 * Cortex-M4F vector table and reset handler that turn the FPU on, copy .data, clear .bss and
 * exit through semihosting with main()'s return code; file I/O through ARM semihosting; and
 * SysTick as a free-running 24-bit counter of QEMU's virtual time. Faults exit with code 3. */
#ifndef QEMU_SEMIHOST_H
#define QEMU_SEMIHOST_H

#include <stdint.h>

#define SH_OPEN_RB 1u /* semihosting SYS_OPEN modes: "rb" and "wb" */
#define SH_OPEN_WB 5u
#define SH_BAD_HANDLE 0xFFFFFFFFu

#define SYST_CVR (*(volatile uint32_t *)0xE000E018u)
#define SYST_MASK 0xFFFFFFu /* SysTick counts down over 24 bits */

int main(void);

/* Open `name` (`len` bytes, no terminator needed) in `mode`: a handle, or SH_BAD_HANDLE. */
uint32_t sh_open(const char *name, uint32_t len, uint32_t mode);
/* Bytes NOT read (0: all of them), as the semihosting call returns. */
uint32_t sh_read(uint32_t handle, void *buf, uint32_t n);
/* Write all `n` bytes or exit with code 4. */
void sh_write(uint32_t handle, const void *buf, uint32_t n);
void sh_close(uint32_t handle);
__attribute__((noreturn)) void sh_exit(uint32_t code);

/* SysTick free-running from its full reload on the core clock (QEMU: virtual time). */
void systick_start(void);
/* SysTick ticks a busy loop of `iterations` two-instruction passes takes. */
uint32_t systick_spin(uint32_t iterations);

#endif
