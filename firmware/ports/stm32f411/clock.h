/* System clock: 96 MHz through the PLL from the 25 MHz crystal; if the crystal (or the PLL
 * from it) does not start within its bound, 96 MHz through the PLL from the 16 MHz internal RC
 * (HSI), so the UART keeps its divider, but USB stays off (HSI is too coarse for its 48 MHz);
 * if the PLL does not lock at all, the raw 16 MHz HSI (the board runs, slower, the UART 2.1 %
 * off speed). Every wait is bounded. */
#ifndef CLOCK_H
#define CLOCK_H

#include <stddef.h>
#include <stdint.h>

/* Which path clock_init took (clocks_t.source). */
#define CLOCK_SRC_HSI 0u     /* 16 MHz internal RC, PLL off: crystal and PLL both failed */
#define CLOCK_SRC_HSI_PLL 1u /* 96 MHz, PLL from the internal RC: the crystal failed */
#define CLOCK_SRC_HSE_PLL 2u /* 96 MHz, PLL from the 25 MHz crystal: the normal start */

typedef struct clocks {
    uint32_t sys_hz;  /* core, SysTick, AHB */
    uint32_t apb1_hz; /* I2C */
    uint32_t apb2_hz; /* USART1 */
    uint32_t tim_hz;  /* TIM2..5 kernel clock (APB1 timers run at 2x a divided APB1) */
    uint8_t source;   /* CLOCK_SRC_* */
    uint8_t usb_ok;   /* 1 when PLL48CLK is 48 MHz from the crystal: USB may start */
} clocks_t;

void clock_init(clocks_t *out);

/* The boot LOG's line for a degraded start: which path ran, whether USB is off and the
 * UART's speed error at `baud` (e.g. "clock HSI+PLL 96MHz (crystal failed): no USB,
 * UART +0.16%"). NULL on the crystal's path, which needs no word. The text lives in a static
 * buffer. */
const char *clock_note(const clocks_t *clk, uint32_t baud);

#endif /* CLOCK_H */
