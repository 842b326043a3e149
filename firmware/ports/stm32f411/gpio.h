/* Pin set-up from the board pin table (board.h). */
#ifndef GPIO_H
#define GPIO_H

#include <stdint.h>

#include "regs.h"

/* Alternate function `af`, open drain or push-pull, optional pull-up. */
void gpio_af(gpio_t *port, uint8_t pin, uint8_t af, int open_drain, int pull_up);
/* Plain open-drain output (I2C bus clearing), level 1 = released. */
void gpio_od_out(gpio_t *port, uint8_t pin, int level);
void gpio_write(gpio_t *port, uint8_t pin, int level);
int gpio_read(const gpio_t *port, uint8_t pin);
gpio_t *gpio_port(char name);

/* Enable the GPIO clocks and configure every pin of the board table. */
void gpio_init_board(void);

#endif /* GPIO_H */
