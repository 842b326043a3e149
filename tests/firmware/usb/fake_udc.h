/* A fake USB device controller: records what the core asks of it, and helpers that play the
 * host's side of whole control transfers. */
#ifndef FAKE_UDC_H
#define FAKE_UDC_H

#include <stdint.h>

#include "usb_dev.h"

#define FAKE_MAX_PACKETS 16u

typedef struct fake_udc {
    uint8_t packets[FAKE_MAX_PACKETS][USB_EP0_SIZE]; /* EP0 IN packets not yet collected */
    uint32_t packet_len[FAKE_MAX_PACKETS];
    uint32_t queued;        /* packets waiting in the list above */
    uint32_t sends;         /* ep0_send calls in total */
    uint32_t receives;      /* ep0_receive calls */
    uint32_t stalls;        /* ep0_stall calls */
    int hw_address;         /* last set_address value, -1 before any */
    uint32_t set_address_calls;
    int configured;         /* last configure() value */
    uint32_t configure_calls;
    uint8_t halt_ep, halt_value;
    uint32_t halt_calls;
} fake_udc_t;

/* Result of one control transfer played from the host side. */
typedef struct xfer {
    int stalled;            /* the device answered with STALL (at any stage) */
    uint32_t len;           /* data-stage bytes received (IN) */
    uint32_t packets;       /* data-stage packets, a final zero-length one included */
    int zlp;                /* the data stage ended with a zero-length packet */
    uint8_t data[512];
} xfer_t;

extern const usb_driver_t g_fake_driver;         /* address after the status stage */
extern const usb_driver_t g_fake_driver_early;   /* address before it, as OTG cores need */

void fake_init(fake_udc_t *f);

/* A whole transfer: SETUP, the data stage (IN: collected; OUT: `out` of its wLength bytes sent
 * in packets of USB_EP0_SIZE) and the status stage. */
xfer_t control(usb_dev_t *dev, fake_udc_t *f, uint8_t bm, uint8_t request, uint16_t value,
               uint16_t index, uint16_t length, const uint8_t *out);

/* Bring a fresh device to the Configured state at `address` through real requests. */
void enumerate(usb_dev_t *dev, fake_udc_t *f, const usb_driver_t *drv, uint8_t address);

#endif /* FAKE_UDC_H */
