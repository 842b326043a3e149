/* Microsecond clock from SysTick: a 1 ms interrupt counts milliseconds and the down-counter
 * gives the fraction; wraps at 2^32 µs like the protocol's timestamps. */
#ifndef SYSTICK_H
#define SYSTICK_H

#include <stdint.h>

void systick_init(uint32_t sys_hz);
uint32_t systick_now_us(void);

#endif /* SYSTICK_H */
