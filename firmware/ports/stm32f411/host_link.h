/* The host link the core's HAL link_write/link_read go through. Two implementations, one per
 * PlatformIO env: host_link_uart.c (USART1 on PA9/PA10 through a USB-serial adapter, env
 * blackpill_uart) and usb_otg_fs.c (USB CDC-ACM on the USB-C port, env blackpill). */
#ifndef HOST_LINK_H
#define HOST_LINK_H

#include <stdint.h>

#include "clock.h"

void host_link_init(const clocks_t *clk, const uint8_t uid[12]);
/* All or nothing: len if the frame was queued, else 0 (full, or nobody listening). */
uint32_t host_link_write(const uint8_t *data, uint32_t len);
uint32_t host_link_read(uint8_t *buf, uint32_t cap);
/* Move queued bytes on; never waits (superloop and inside bounded I2C waits). */
void host_link_service(void);
/* Send what is queued, waiting at most timeout_us (before a reset: the ACK must leave first). */
void host_link_flush(uint32_t timeout_us);
/* 1 while the host has suspended the bus (USB); the UART link is never suspended. */
int host_link_suspended(void);

#endif /* HOST_LINK_H */
