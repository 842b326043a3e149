/* Portable USB device core: the chapter-9 device state machine, endpoint-0 control transfers
 * and the CDC-ACM class requests, driven by events from a controller driver (the STM32F411
 * OTG_FS driver on the board, the unit tests on the host). No heap; no waits: every event is
 * handled in bounded time and the driver is told what to do next through usb_driver_t.
 *
 * Event order for a control transfer, as the driver reports it:
 *   usb_dev_setup(8 bytes) -> [usb_dev_ep0_out(data) ... | usb_dev_ep0_in_done() ...]
 *   -> status stage: usb_dev_ep0_in_done() (ZLP sent) or usb_dev_ep0_out(len 0). */
#ifndef USB_DEV_H
#define USB_DEV_H

#include <stdint.h>

#include "usb_desc.h"

/* USB 2.0 §9.1.1 (Figure 9-1), without Attached/Powered which the driver does not report. */
typedef enum {
    USB_STATE_DEFAULT = 0,
    USB_STATE_ADDRESS = 1,
    USB_STATE_CONFIGURED = 2,
    USB_STATE_SUSPENDED = 3
} usb_state_t;

/* Where endpoint 0 is within a control transfer (USB 2.0 §8.5.3). */
typedef enum {
    USB_EP0_IDLE = 0,       /* waiting for SETUP */
    USB_EP0_DATA_IN = 1,    /* sending the data stage */
    USB_EP0_DATA_OUT = 2,   /* receiving the data stage */
    USB_EP0_STATUS_IN = 3,  /* the zero-length status packet is queued */
    USB_EP0_STATUS_OUT = 4, /* waiting for the host's zero-length status packet */
    USB_EP0_STALLED = 5     /* request error: both directions STALL until the next SETUP */
} usb_ep0_stage_t;

/* What the core asks of the controller. Every call returns at once. */
typedef struct usb_driver {
    /* Queue one packet (at most USB_EP0_SIZE bytes, 0 = zero-length) on EP0 IN; completion is
     * reported with usb_dev_ep0_in_done. */
    void (*ep0_send)(void *ctx, const uint8_t *data, uint32_t len);
    /* Accept one packet on EP0 OUT (data stage or zero-length status stage). */
    void (*ep0_receive)(void *ctx);
    /* STALL EP0 IN and OUT; the controller clears it when the next SETUP arrives. */
    void (*ep0_stall)(void *ctx);
    /* Program the device address into the controller. */
    void (*set_address)(void *ctx, uint8_t address);
    /* Activate (1) or deactivate (0) the CDC endpoints; activation resets data toggles. */
    void (*configure)(void *ctx, uint8_t on);
    /* Set (1) or clear (0) the halt feature of a data endpoint; clearing resets its toggle. */
    void (*ep_halt)(void *ctx, uint8_t ep_address, uint8_t halt);
    /* 1: the controller needs the address before the status stage (Synopsys OTG cores answer
     * the status stage on the old address by themselves); 0: after it, as USB 2.0 §9.4.6. */
    uint8_t address_before_status;
} usb_driver_t;

/* PSTN 1.2 §6.3.10 Table 17. */
typedef struct usb_line_coding {
    uint32_t rate;     /* dwDTERate, bit/s */
    uint8_t stop_bits; /* bCharFormat: 0 = 1, 1 = 1.5, 2 = 2 */
    uint8_t parity;    /* bParityType: 0 none, 1 odd, 2 even, 3 mark, 4 space */
    uint8_t data_bits; /* bDataBits: 5, 6, 7, 8 or 16 */
} usb_line_coding_t;

typedef struct usb_dev {
    const usb_driver_t *drv;
    void *ctx;
    usb_state_t state;
    usb_state_t state_before_suspend;
    uint8_t address;
    uint8_t pending_address; /* SET_ADDRESS waiting for its status stage */
    uint8_t configuration;
    usb_ep0_stage_t ep0;
    uint8_t setup[8];
    const uint8_t *in_data; /* rest of the IN data stage */
    uint32_t in_left;
    uint8_t in_zlp;          /* a zero-length packet ends the data stage (USB 2.0 §5.5.3) */
    uint8_t out_len;         /* bytes of the OUT data stage received so far */
    uint8_t out_buf[8];      /* the longest OUT data stage we accept: a line coding */
    uint8_t reply[8];        /* small IN answers: status, configuration, line coding */
    uint8_t halted;          /* bit 0 data OUT, 1 data IN, 2 notification IN */
    usb_line_coding_t line;
    uint16_t control_lines;  /* SET_CONTROL_LINE_STATE wValue: bit 0 DTR, bit 1 RTS */
    uint32_t port_closes;    /* DTR dropped on the open port; the driver then drops what is
                              * queued to send, which the next program must not read */
    uint16_t break_ms;       /* last SEND_BREAK duration */
    uint32_t stalls;         /* request errors answered with STALL */
    uint8_t serial[USB_SERIAL_DESC_LEN];
} usb_dev_t;

void usb_dev_init(usb_dev_t *dev, const usb_driver_t *drv, void *ctx, const uint8_t uid[12]);

/* Bus events. */
void usb_dev_bus_reset(usb_dev_t *dev);
void usb_dev_suspend(usb_dev_t *dev);
void usb_dev_resume(usb_dev_t *dev);

/* Endpoint 0 events. */
void usb_dev_setup(usb_dev_t *dev, const uint8_t packet[8]);
void usb_dev_ep0_in_done(usb_dev_t *dev);
void usb_dev_ep0_out(usb_dev_t *dev, const uint8_t *data, uint32_t len);

/* Length of an IN data stage answering `len` bytes to a request of wLength, and whether a
 * zero-length packet must end it: when it is shorter than wLength and ends on a full packet
 * (USB 2.0 §5.5.3, §8.5.3.2). */
uint32_t usb_ep0_data_stage(uint32_t len, uint16_t w_length, uint8_t *zlp);

/* CDC-ACM view: configured and the host holds DTR, i.e. a program has the port open. */
int usb_cdc_port_open(const usb_dev_t *dev);

#endif /* USB_DEV_H */
