/* Interrupt priorities. The F411 implements the top 4 bits of each 8-bit priority (0 is the
 * highest); every interrupt left at reset runs at 0. The host link's interrupt (USART1 or
 * OTG_FS) runs at the lowest level the port uses, so that anything with a deadline preempts it;
 * the clock needs no interrupt at all (TIM5's counter, timebase.h). */
#ifndef STM32F411_IRQ_H
#define STM32F411_IRQ_H

#include <stdint.h>

#include "regs.h"

#define IRQ_PRIORITY_LINK 0xC0u

/* Set interrupt irqn's 8-bit priority (NVIC_IPR holds four per word), then enable it. */
static inline void irq_enable(uint32_t irqn, uint32_t priority) {
    const uint32_t shift = 8u * (irqn % 4u);
    NVIC_IPR(irqn / 4u) = (NVIC_IPR(irqn / 4u) & ~(0xFFu << shift)) | ((priority & 0xFFu) << shift);
    NVIC_ISER(irqn / 32u) = 1u << (irqn % 32u);
}

#endif /* STM32F411_IRQ_H */
