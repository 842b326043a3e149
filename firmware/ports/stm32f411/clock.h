/* System clock: 96 MHz from the 25 MHz crystal through the PLL, or the 16 MHz internal RC if
 * the crystal or PLL does not start within its bound (then the board still runs, slower). */
#ifndef CLOCK_H
#define CLOCK_H

#include <stdint.h>

typedef struct clocks {
    uint32_t sys_hz;  /* core, SysTick, AHB */
    uint32_t apb1_hz; /* I2C */
    uint32_t apb2_hz; /* USART1 */
    uint32_t tim_hz;  /* TIM2..4 kernel clock (APB1 timers run at 2x a divided APB1) */
    uint8_t on_pll;   /* 1 when the PLL came up */
} clocks_t;

void clock_init(clocks_t *out);

#endif /* CLOCK_H */
