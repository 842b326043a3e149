#include "gpio.h"

#include "generated/board.h"

/* OSPEEDR code 00, low speed (RM0383 8.4.3); regs.h names only the non-zero codes. */
#define GPIO_SPEED_LOW 0u

gpio_t *gpio_port(char name) {
    return name == 'A' ? GPIOA : GPIOB;
}

/* Set pin `pin`'s field of a per-pin register; mask0 is pin 0's field (regs.h), whose width
 * is every pin's. */
static void set_field(volatile uint32_t *reg, uint8_t pin, uint32_t mask0, uint32_t value) {
    uint32_t width = 0u;
    while ((mask0 >> width) != 0u) {
        width++;
    }
    const uint32_t shift = (uint32_t)pin * width;
    const uint32_t mask = mask0 << shift;
    *reg = (*reg & ~mask) | ((value << shift) & mask);
}

/* The output speed (slew) is set before the pin is handed to its peripheral, so it never
 * switches at a faster edge than it keeps. */
static void pin_af(gpio_t *port, uint8_t pin, uint8_t af, int open_drain, int pull_up,
                   uint32_t speed) {
    set_field(&port->AFR[pin / 8u], (uint8_t)(pin % 8u), GPIO_AFRL_AFRL0_MASK, af);
    set_field(&port->OTYPER, pin, GPIO_OTYPER_OT0, open_drain ? 1u : 0u);
    set_field(&port->OSPEEDR, pin, GPIO_OSPEEDR_OSPEEDR0_MASK, speed);
    set_field(&port->PUPDR, pin, GPIO_PUPDR_PUPDR0_MASK, pull_up ? GPIO_PUPDR_PUPDR0_PULLUP : 0u);
    set_field(&port->MODER, pin, GPIO_MODER_MODER0_MASK, GPIO_MODER_MODER0_AF);
}

void gpio_af(gpio_t *port, uint8_t pin, uint8_t af, int open_drain, int pull_up) {
    /* fast: clean 400 kHz I2C edges, USB, the UART */
    pin_af(port, pin, af, open_drain, pull_up, GPIO_OSPEEDR_OSPEEDR0_FAST);
}

void gpio_od_out(gpio_t *port, uint8_t pin, int level) {
    gpio_write(port, pin, level);
    set_field(&port->OTYPER, pin, GPIO_OTYPER_OT0, 1u);
    set_field(&port->MODER, pin, GPIO_MODER_MODER0_MASK, GPIO_MODER_MODER0_OUTPUT);
}

void gpio_write(gpio_t *port, uint8_t pin, int level) {
    port->BSRR = level ? (GPIO_BSRR_BS0 << pin) : (GPIO_BSRR_BR0 << pin);
}

int gpio_read(const gpio_t *port, uint8_t pin) {
    return (int)((port->IDR >> pin) & 1u);
}

void gpio_init_board(void) {
    RCC->AHB1ENR |= RCC_AHB1ENR_GPIOA | RCC_AHB1ENR_GPIOB;
    (void)RCC->AHB1ENR; /* let the clock enable settle before touching the ports */
    for (uint32_t i = 0; i < BOARD_PIN_COUNT; i++) {
        const board_pin_t *p = &k_board_pins[i];
        gpio_t *port = gpio_port(p->port);
        switch (p->role) {
        case PIN_I2C_SCL:
        case PIN_I2C_SDA:
            gpio_af(port, p->pin, p->af, 1, 1); /* open drain; board pull-ups, internal as backup */
            break;
        case PIN_LED:
            /* Open drain sinks the cathode (active low). Low speed: 20 kHz PWM needs no fast
             * edges, and slow ones couple less into SDA/SCL next to them. */
            pin_af(port, p->pin, p->af, 1, 0, GPIO_SPEED_LOW);
            break;
        case PIN_UART_RX:
            gpio_af(port, p->pin, p->af, 0, 1); /* idle high if the adapter is unplugged */
            break;
        default:
            gpio_af(port, p->pin, p->af, 0, 0);
            break;
        }
    }
}
