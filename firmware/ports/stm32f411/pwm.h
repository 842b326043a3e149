/* LED drive: nine timer channels (TIM2 CH1-4, TIM3 CH1-4, TIM4 CH3) at ~20 kHz, open drain,
 * active low (the pin sinks the LED cathode; pin low = LED on). */
#ifndef PWM_H
#define PWM_H

#include <stdint.h>

void pwm_init(uint32_t tim_hz);
/* led 0..2, colour 0 R / 1 G / 2 B, duty in permille (0 off .. 1000 fully on). */
void pwm_set(uint8_t led, uint8_t colour, uint16_t duty_permille);

#endif /* PWM_H */
