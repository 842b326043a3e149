/* Host link over USART1 (env blackpill_uart): the board's original 921600 8N1 serial link. */
#include "generated/board.h"
#include "host_link.h"
#include "timebase.h"
#include "uart.h"

void host_link_init(const clocks_t *clk, const uint8_t uid[12]) {
    (void)uid;
    uart_init(clk->apb2_hz, BOARD_BAUD);
}

uint32_t host_link_write(const uint8_t *data, uint32_t len) {
    return uart_write(data, len);
}

uint32_t host_link_read(uint8_t *buf, uint32_t cap) {
    return uart_read(buf, cap);
}

void host_link_service(void) {
    uart_service();
}

void host_link_flush(uint32_t timeout_us) {
    const uint32_t t0 = timebase_now_us();
    while ((uart_tx_queued() != 0u || !uart_tx_done()) && timebase_now_us() - t0 < timeout_us) {
        uart_service(); /* until the frame's last byte (its delimiter) has left the pin */
    }
}

int host_link_suspended(void) {
    return 0;
}
