/* USART1 host link at 921600 baud (8N1). Received bytes go into a ring from the RX interrupt
 * (an I2C transfer may keep the superloop away for a few ms); frames to send go into a ring
 * that the TXE interrupt drains, so a frame leaves while the superloop decodes; uart_service()
 * also drains it from the main context (where no TXE interrupt arrives, as under QEMU). */
#ifndef UART_H
#define UART_H

#include <stdint.h>

/* USART_BRR for `baud` from the kernel clock, 16x oversampling: BRR is the mantissa.fraction/16
 * divider, so the rate is clk_hz / BRR, rounded to the nearest (clock_note reports the error). */
static inline uint32_t uart_brr(uint32_t clk_hz, uint32_t baud) {
    return (clk_hz + baud / 2u) / baud;
}

void uart_init(uint32_t apb2_hz, uint32_t baud);
/* All or nothing: returns len if the frame fits the transmit ring, else 0. */
uint32_t uart_write(const uint8_t *data, uint32_t len);
uint32_t uart_read(uint8_t *buf, uint32_t cap);
/* Move queued bytes into the transmitter while it has room; never waits. */
void uart_service(void);
/* Bytes queued and not yet handed to the transmitter. */
uint32_t uart_tx_queued(void);
/* 1 once the last byte handed over has left the pin (TC), e.g. before a reset. */
int uart_tx_done(void);
/* Received bytes lost to a full ring or a hardware overrun. */
uint32_t uart_rx_lost(void);

#endif /* UART_H */
