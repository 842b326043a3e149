#include "gpio.h"

#include "generated/board.h"

gpio_t *gpio_port(char name) {
    return name == 'A' ? GPIOA : GPIOB;
}

static void set_field(volatile uint32_t *reg, uint8_t pin, uint32_t bits, uint32_t value) {
    const uint32_t shift = (uint32_t)pin * bits;
    const uint32_t mask = ((1u << bits) - 1u) << shift;
    *reg = (*reg & ~mask) | ((value << shift) & mask);
}

void gpio_af(gpio_t *port, uint8_t pin, uint8_t af, int open_drain, int pull_up) {
    set_field(&port->AFR[pin / 8u], (uint8_t)(pin % 8u), 4u, af);
    set_field(&port->OTYPER, pin, 1u, open_drain ? 1u : 0u);
    set_field(&port->OSPEEDR, pin, 2u, 2u); /* fast: clean 400 kHz edges */
    set_field(&port->PUPDR, pin, 2u, pull_up ? 1u : 0u);
    set_field(&port->MODER, pin, 2u, 2u);
}

void gpio_od_out(gpio_t *port, uint8_t pin, int level) {
    gpio_write(port, pin, level);
    set_field(&port->OTYPER, pin, 1u, 1u);
    set_field(&port->MODER, pin, 2u, 1u);
}

void gpio_write(gpio_t *port, uint8_t pin, int level) {
    port->BSRR = level ? (1u << pin) : (1u << (pin + 16u));
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
            gpio_af(port, p->pin, p->af, 1, 0); /* open drain sinks the cathode: active low */
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
