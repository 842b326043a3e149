/* Masking interrupts around the few instructions the I2C master must not be late for
 * (RM0383 18.3.3: between clearing ADDR and programming ACK/STOP). On the target, PRIMASK;
 * a host build (the register model in tests/firmware/i2c) supplies the two functions. */
#ifndef IRQ_H
#define IRQ_H

#include <stdint.h>

#if defined(__arm__)
static inline uint32_t irq_save(void) {
    uint32_t primask;
    __asm volatile("mrs %0, primask\n\tcpsid i" : "=r"(primask)::"memory");
    return primask;
}

static inline void irq_restore(uint32_t primask) {
    __asm volatile("msr primask, %0" ::"r"(primask) : "memory");
}
#else
uint32_t irq_save(void);
void irq_restore(uint32_t primask);
#endif

#endif /* IRQ_H */
