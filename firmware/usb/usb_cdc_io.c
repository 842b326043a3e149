#include "usb_cdc_io.h"

#include <stdatomic.h>
#include <string.h>

void usb_cdc_io_init(usb_cdc_io_t *io) {
    memset(io, 0, sizeof *io);
}

uint32_t usb_cdc_io_write(usb_cdc_io_t *io, const uint8_t *data, uint32_t len) {
    const uint32_t head = io->tx_head;
    if (USB_CDC_TX_SIZE - (head - io->tx_tail) < len) {
        return 0u;
    }
    for (uint32_t i = 0; i < len; i++) {
        io->tx[(head + i) % USB_CDC_TX_SIZE] = data[i];
    }
    /* The bytes are in the ring before the interrupt can see the new head. */
    atomic_signal_fence(memory_order_seq_cst);
    io->tx_head = head + len;
    return len;
}

uint32_t usb_cdc_io_read(usb_cdc_io_t *io, uint8_t *buf, uint32_t cap) {
    uint32_t n = 0u;
    uint32_t tail = io->rx_tail;
    const uint32_t head = io->rx_head;
    atomic_signal_fence(memory_order_seq_cst);
    while (tail != head && n < cap) {
        buf[n++] = io->rx[tail % USB_CDC_RX_SIZE];
        tail++;
    }
    atomic_signal_fence(memory_order_seq_cst);
    io->rx_tail = tail;
    return n;
}

uint32_t usb_cdc_io_tx_queued(const usb_cdc_io_t *io) {
    return io->tx_head - io->tx_tail;
}

int usb_cdc_io_next_packet(usb_cdc_io_t *io, uint8_t packet[USB_DATA_SIZE], uint32_t *len) {
    const uint32_t tail = io->tx_tail;
    const uint32_t queued = io->tx_head - tail;
    atomic_signal_fence(memory_order_seq_cst);
    if (queued == 0u && io->tx_last_full == 0u) {
        return 0;
    }
    const uint32_t n = queued < USB_DATA_SIZE ? queued : USB_DATA_SIZE;
    for (uint32_t i = 0; i < n; i++) {
        packet[i] = io->tx[(tail + i) % USB_CDC_TX_SIZE];
    }
    atomic_signal_fence(memory_order_seq_cst);
    io->tx_tail = tail + n;
    /* A full packet with nothing behind it leaves the host's transfer open: Linux cdc_acm
     * reads in multi-packet URBs that complete only on a short (or zero-length) packet. */
    io->tx_last_full = (uint8_t)(n == USB_DATA_SIZE);
    *len = n;
    return 1;
}

void usb_cdc_io_drop_tx(usb_cdc_io_t *io) {
    io->tx_tail = io->tx_head;
    io->tx_last_full = 0u;
}

int usb_cdc_io_rx_room(const usb_cdc_io_t *io) {
    return USB_CDC_RX_SIZE - (io->rx_head - io->rx_tail) >= USB_DATA_SIZE;
}

void usb_cdc_io_rx_push(usb_cdc_io_t *io, const uint8_t *data, uint32_t len) {
    const uint32_t head = io->rx_head;
    for (uint32_t i = 0; i < len; i++) {
        io->rx[(head + i) % USB_CDC_RX_SIZE] = data[i];
    }
    atomic_signal_fence(memory_order_seq_cst);
    io->rx_head = head + len;
}
