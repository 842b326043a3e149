/* The CDC-ACM data path between the superloop and the controller's interrupt: a transmit ring
 * cut into bulk IN packets (with the zero-length packet that ends a transfer on a packet
 * boundary) and a receive ring that takes whole OUT packets only when it has room for one.
 * One producer and one consumer per ring (main context / interrupt), so no locks: each index
 * is written by one side only. */
#ifndef USB_CDC_IO_H
#define USB_CDC_IO_H

#include <stdint.h>

#include "usb_desc.h"

#define USB_CDC_TX_SIZE 2048u /* power of two: several whole frames */
#define USB_CDC_RX_SIZE 512u  /* power of two, at least two packets */

typedef struct usb_cdc_io {
    uint8_t tx[USB_CDC_TX_SIZE];
    volatile uint32_t tx_head; /* written by the main context */
    volatile uint32_t tx_tail; /* written by the interrupt */
    uint8_t tx_last_full;      /* the last packet was full: a ZLP is owed if nothing follows */
    uint8_t rx[USB_CDC_RX_SIZE];
    volatile uint32_t rx_head; /* written by the interrupt */
    volatile uint32_t rx_tail; /* written by the main context */
} usb_cdc_io_t;

void usb_cdc_io_init(usb_cdc_io_t *io);

/* Main context. All or nothing: len if the bytes fit the transmit ring, else 0. */
uint32_t usb_cdc_io_write(usb_cdc_io_t *io, const uint8_t *data, uint32_t len);
/* Main context: up to cap received bytes, without waiting. */
uint32_t usb_cdc_io_read(usb_cdc_io_t *io, uint8_t *buf, uint32_t cap);
uint32_t usb_cdc_io_tx_queued(const usb_cdc_io_t *io);

/* Interrupt: the next bulk IN packet into `packet`; returns 1 and its length in *len (0 for
 * the zero-length packet that ends a transfer of whole packets), or 0 when nothing is due. */
int usb_cdc_io_next_packet(usb_cdc_io_t *io, uint8_t packet[USB_DATA_SIZE], uint32_t *len);
/* Interrupt: drop everything queued for transmission (the host deconfigured the device). */
void usb_cdc_io_drop_tx(usb_cdc_io_t *io);
/* Interrupt: whether a whole OUT packet fits (else the endpoint must keep NAKing). */
int usb_cdc_io_rx_room(const usb_cdc_io_t *io);
/* Interrupt: store a received OUT packet; call only after usb_cdc_io_rx_room said yes. */
void usb_cdc_io_rx_push(usb_cdc_io_t *io, const uint8_t *data, uint32_t len);

#endif /* USB_CDC_IO_H */
