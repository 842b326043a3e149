/* Board-level constants and the pin table of the Black Pill port.
 *
 * k_board_pins is the port's copy of pinmap.toml (tests/firmware/test_pinmap.py checks that
 * both agree, so the KiCad board and this firmware cannot drift apart). */
#ifndef BOARD_H
#define BOARD_H

#include <stdint.h>

#define BOARD_NAME "blackpill-f411"
#define BOARD_HSE_HZ 25000000u /* Black Pill crystal */
#define BOARD_BAUD 921600u
#define BOARD_PWM_HZ 20000u    /* ~1000 PWM periods per 50 ms integration */

enum pin_role { PIN_I2C_SCL, PIN_I2C_SDA, PIN_LED, PIN_UART_TX, PIN_UART_RX };

typedef struct board_pin {
    const char *signal; /* as in pinmap.toml */
    char port;          /* 'A' or 'B' */
    uint8_t pin;
    uint8_t af;         /* alternate function number */
    uint8_t role;       /* enum pin_role */
    uint8_t unit;       /* I2C bus 1..3, timer 2..4, or USART 1 */
    uint8_t channel;    /* timer channel 1..4 (LEDs), else 0 */
} board_pin_t;

/* Sensor k on I2C bus k+1; LED j colour c on k_board_pins[BOARD_LED_FIRST + 3j + c]. */
#define BOARD_LED_FIRST 6u
#define BOARD_PIN_COUNT 17u

static const board_pin_t k_board_pins[BOARD_PIN_COUNT] = {
    {"SCL1", 'B', 6, 4, PIN_I2C_SCL, 1, 0},
    {"SDA1", 'B', 7, 4, PIN_I2C_SDA, 1, 0},
    {"SCL2", 'B', 10, 4, PIN_I2C_SCL, 2, 0},
    {"SDA2", 'B', 3, 9, PIN_I2C_SDA, 2, 0},
    {"SCL3", 'A', 8, 4, PIN_I2C_SCL, 3, 0},
    {"SDA3", 'B', 4, 9, PIN_I2C_SDA, 3, 0},
    {"LED1_R", 'A', 0, 1, PIN_LED, 2, 1},
    {"LED1_G", 'A', 1, 1, PIN_LED, 2, 2},
    {"LED1_B", 'A', 2, 1, PIN_LED, 2, 3},
    {"LED2_R", 'A', 3, 1, PIN_LED, 2, 4},
    {"LED2_G", 'A', 6, 2, PIN_LED, 3, 1},
    {"LED2_B", 'A', 7, 2, PIN_LED, 3, 2},
    {"LED3_R", 'B', 0, 2, PIN_LED, 3, 3},
    {"LED3_G", 'B', 1, 2, PIN_LED, 3, 4},
    {"LED3_B", 'B', 8, 2, PIN_LED, 4, 3},
    {"TX", 'A', 9, 7, PIN_UART_TX, 1, 0},
    {"RX", 'A', 10, 7, PIN_UART_RX, 1, 0},
};

#endif /* BOARD_H */
