/* The device's microsecond clock: TIM5, the F411's 32-bit general-purpose timer, counting at
 * 1 MHz from the APB1 timer clock and wrapping at 2^32 us like the protocol's timestamps. A
 * hardware counter keeps counting while a flash erase stalls the core (up to 2 s a sector),
 * which a SysTick interrupt counting milliseconds could not: timestamps, uptime and time sync
 * do not step across MODEL_BEGIN or MODEL_CLEAR. No interrupt is involved. */
#ifndef STM32F411_TIMEBASE_H
#define STM32F411_TIMEBASE_H

#include <stdint.h>

/* The prescaler that divides tim_hz to 1 MHz (PSC + 1 = tim_hz / 1 MHz). */
static inline uint32_t timebase_prescaler(uint32_t tim_hz) {
    return tim_hz / 1000000u - 1u;
}

void timebase_init(uint32_t tim_hz);
uint32_t timebase_now_us(void);

#endif /* STM32F411_TIMEBASE_H */
