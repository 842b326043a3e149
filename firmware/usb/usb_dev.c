/* Chapter-9 device core and CDC-ACM class requests. References: USB 2.0 §9.1.1 (device
 * states), §8.5.3 (control transfer stages), §5.5.3 (ending a data stage: a short packet or a
 * zero-length one), §9.3 (SETUP layout, Table 9-2), §9.4 (standard requests, Tables 9-3..9-6),
 * CDC 1.2 §6.2 and PSTN 1.2 §6.3 (class requests, Table 13 / Tables 17-18). */
#include "usb_dev.h"

#include <string.h>

/* bmRequestType fields (USB 2.0 Table 9-2). */
#define RT_IN 0x80u
#define RT_TYPE(bm) (((bm) >> 5) & 3u)
#define RT_RECIPIENT(bm) ((bm) & 0x1Fu)
#define TYPE_STANDARD 0u
#define TYPE_CLASS 1u
#define TO_DEVICE 0u
#define TO_INTERFACE 1u
#define TO_ENDPOINT 2u

/* Standard request codes (Table 9-4), descriptor types (Table 9-5), features (Table 9-6). */
enum {
    REQ_GET_STATUS = 0x00,
    REQ_CLEAR_FEATURE = 0x01,
    REQ_SET_FEATURE = 0x03,
    REQ_SET_ADDRESS = 0x05,
    REQ_GET_DESCRIPTOR = 0x06,
    REQ_GET_CONFIGURATION = 0x08,
    REQ_SET_CONFIGURATION = 0x09,
    REQ_GET_INTERFACE = 0x0A,
    REQ_SET_INTERFACE = 0x0B
};
enum { DT_DEVICE = 1, DT_CONFIGURATION = 2, DT_STRING = 3 };
#define FEATURE_ENDPOINT_HALT 0u

/* CDC class request codes (CDC 1.2 Table 19, PSTN 1.2 Table 13). */
enum {
    CDC_SET_LINE_CODING = 0x20,
    CDC_GET_LINE_CODING = 0x21,
    CDC_SET_CONTROL_LINE_STATE = 0x22,
    CDC_SEND_BREAK = 0x23
};
#define LINE_CODING_LEN 7u

typedef struct {
    uint8_t bm, request;
    uint16_t value, index, length;
} setup_t;

static setup_t parse(const uint8_t p[8]) {
    setup_t s;
    s.bm = p[0];
    s.request = p[1];
    s.value = (uint16_t)(p[2] | (p[3] << 8));
    s.index = (uint16_t)(p[4] | (p[5] << 8));
    s.length = (uint16_t)(p[6] | (p[7] << 8));
    return s;
}

static void stall(usb_dev_t *dev) {
    dev->ep0 = USB_EP0_STALLED;
    dev->in_left = 0u;
    dev->in_zlp = 0u;
    dev->stalls++;
    dev->drv->ep0_stall(dev->ctx);
}

static void status_in(usb_dev_t *dev) {
    dev->ep0 = USB_EP0_STATUS_IN;
    dev->drv->ep0_send(dev->ctx, 0, 0u);
}

static void send_next(usb_dev_t *dev) {
    if (dev->in_left > 0u) {
        const uint32_t n = dev->in_left < USB_EP0_SIZE ? dev->in_left : USB_EP0_SIZE;
        const uint8_t *p = dev->in_data;
        dev->in_data += n;
        dev->in_left -= n;
        dev->drv->ep0_send(dev->ctx, p, n);
    } else if (dev->in_zlp != 0u) {
        dev->in_zlp = 0u;
        dev->drv->ep0_send(dev->ctx, 0, 0u);
    } else {
        dev->ep0 = USB_EP0_STATUS_OUT;
        dev->drv->ep0_receive(dev->ctx);
    }
}

/* Answer an IN request with at most wLength bytes of `data`. A data stage that ends on a full
 * packet before wLength needs a zero-length packet so the host knows it is over (§5.5.3). */
uint32_t usb_ep0_data_stage(uint32_t len, uint16_t w_length, uint8_t *zlp) {
    const uint32_t n = len < w_length ? len : w_length;
    *zlp = (uint8_t)(n < w_length && n % USB_EP0_SIZE == 0u);
    return n;
}

static int reply_in(usb_dev_t *dev, const setup_t *s, const uint8_t *data, uint32_t len) {
    if ((s->bm & RT_IN) == 0u) {
        return 0;
    }
    if (s->length == 0u) { /* no data stage: straight to the status stage (§8.5.3) */
        status_in(dev);
        return 1;
    }
    dev->in_data = data;
    dev->in_left = usb_ep0_data_stage(len, s->length, &dev->in_zlp);
    dev->ep0 = USB_EP0_DATA_IN;
    send_next(dev);
    return 1;
}

/* A request without data stage (host to device, wLength 0). */
static int no_data(usb_dev_t *dev, const setup_t *s) {
    if ((s->bm & RT_IN) != 0u || s->length != 0u) {
        return 0;
    }
    status_in(dev);
    return 1;
}

static int reply_u16(usb_dev_t *dev, const setup_t *s, uint16_t v) {
    if (s->value != 0u || s->length != 2u) {
        return 0;
    }
    dev->reply[0] = (uint8_t)(v & 0xFFu);
    dev->reply[1] = (uint8_t)(v >> 8);
    return reply_in(dev, s, dev->reply, 2u);
}

static int reply_u8(usb_dev_t *dev, const setup_t *s, uint8_t v) {
    if (s->value != 0u || s->length != 1u) {
        return 0;
    }
    dev->reply[0] = v;
    return reply_in(dev, s, dev->reply, 1u);
}

static int get_descriptor(usb_dev_t *dev, const setup_t *s) {
    const uint8_t type = (uint8_t)(s->value >> 8);
    const uint8_t index = (uint8_t)(s->value & 0xFFu);
    switch (type) {
    case DT_DEVICE:
        return index == 0u && s->index == 0u &&
               reply_in(dev, s, k_usb_device_desc, USB_DEVICE_DESC_LEN);
    case DT_CONFIGURATION:
        return index == 0u && s->index == 0u &&
               reply_in(dev, s, k_usb_config_desc, USB_CONFIG_DESC_LEN);
    case DT_STRING: {
        /* String 0 lists the languages; every other string exists in US English only. */
        if (index != USB_STR_LANGIDS && s->index != USB_LANGID_EN_US) {
            return 0;
        }
        uint16_t len = 0u;
        const uint8_t *d = usb_desc_string(index, dev->serial, &len);
        return d != 0 && reply_in(dev, s, d, len);
    }
    default:
        /* Device qualifier and other-speed configuration included: a full-speed-only device
         * answers them with a request error (§9.6.2). */
        return 0;
    }
}

static void set_configured(usb_dev_t *dev, uint8_t value) {
    dev->drv->configure(dev->ctx, 0u);
    dev->halted = 0u;
    dev->control_lines = 0u;
    dev->configuration = value;
    if (value != 0u) {
        dev->drv->configure(dev->ctx, 1u);
        dev->state = USB_STATE_CONFIGURED;
    } else {
        dev->state = USB_STATE_ADDRESS;
    }
}

static int device_request(usb_dev_t *dev, const setup_t *s) {
    switch (s->request) {
    case REQ_GET_STATUS: /* bus powered, remote wake-up off (Figure 9-4) */
        return s->index == 0u && reply_u16(dev, s, 0u);
    case REQ_SET_ADDRESS:
        if (s->value > 127u || s->index != 0u || dev->state == USB_STATE_CONFIGURED) {
            return 0;
        }
        if (!no_data(dev, s)) {
            return 0;
        }
        dev->pending_address = (uint8_t)(s->value | 0x80u); /* bit 7: a change is pending */
        if (dev->drv->address_before_status != 0u) {
            dev->drv->set_address(dev->ctx, (uint8_t)s->value);
        }
        return 1;
    case REQ_GET_DESCRIPTOR:
        return get_descriptor(dev, s);
    case REQ_GET_CONFIGURATION:
        return dev->state != USB_STATE_DEFAULT && s->index == 0u &&
               reply_u8(dev, s, dev->configuration);
    case REQ_SET_CONFIGURATION: {
        const uint8_t value = (uint8_t)(s->value & 0xFFu);
        if (dev->state == USB_STATE_DEFAULT || (s->value >> 8) != 0u || s->index != 0u ||
            (value != 0u && value != USB_CONFIG_VALUE) || (s->bm & RT_IN) != 0u ||
            s->length != 0u) {
            return 0;
        }
        set_configured(dev, value);
        return no_data(dev, s);
    }
    default:
        /* CLEAR/SET_FEATURE: remote wake-up is not offered (bmAttributes bit 5 clear) and test
         * mode is high-speed only; SET_DESCRIPTOR is optional. All are request errors. */
        return 0;
    }
}

static int interface_request(usb_dev_t *dev, const setup_t *s) {
    if (dev->state != USB_STATE_CONFIGURED || s->index >= USB_IF_COUNT) {
        return 0;
    }
    switch (s->request) {
    case REQ_GET_STATUS:
        return reply_u16(dev, s, 0u);
    case REQ_GET_INTERFACE:
        return reply_u8(dev, s, 0u);
    case REQ_SET_INTERFACE:
        /* Only alternate setting 0 exists; selecting it resets the interface's endpoints'
         * halt and data toggle (§9.4.10). */
        if (s->value != 0u || !no_data(dev, s)) {
            return 0;
        }
        if (s->index == USB_IF_DATA) {
            dev->halted &= (uint8_t)~3u;
            dev->drv->ep_halt(dev->ctx, USB_EP_DATA_OUT, 0u);
            dev->drv->ep_halt(dev->ctx, USB_EP_DATA_IN, 0u);
        } else {
            dev->halted &= (uint8_t)~4u;
            dev->drv->ep_halt(dev->ctx, USB_EP_NOTIFY_IN, 0u);
        }
        return 1;
    default:
        return 0; /* interfaces have no features (Table 9-6) */
    }
}

/* Halt bit of a data endpoint in `halted`, or -1 for endpoint 0, or -2 for none of ours. */
static int endpoint_bit(uint16_t index) {
    switch (index) {
    case 0x00u:
    case 0x80u:
        return -1;
    case USB_EP_DATA_OUT:
        return 0;
    case USB_EP_DATA_IN:
        return 1;
    case USB_EP_NOTIFY_IN:
        return 2;
    default:
        return -2;
    }
}

static int endpoint_request(usb_dev_t *dev, const setup_t *s) {
    const int bit = endpoint_bit(s->index);
    /* Address state: only endpoint 0 exists; Default state: not specified, refused (§9.4). */
    if (bit == -2 || dev->state == USB_STATE_DEFAULT ||
        (bit >= 0 && dev->state != USB_STATE_CONFIGURED)) {
        return 0;
    }
    switch (s->request) {
    case REQ_GET_STATUS:
        if (bit < 0) {
            return reply_u16(dev, s, 0u);
        }
        return reply_u16(dev, s, (uint16_t)(((unsigned)dev->halted >> (unsigned)bit) & 1u));
    case REQ_CLEAR_FEATURE:
    case REQ_SET_FEATURE: {
        const uint8_t halt = s->request == REQ_SET_FEATURE;
        /* The default pipe's halt is neither required nor recommended (§9.4.5): clearing it
         * is accepted, setting it is refused. */
        if (s->value != FEATURE_ENDPOINT_HALT || (bit < 0 && halt != 0u) || !no_data(dev, s)) {
            return 0;
        }
        if (bit >= 0) {
            const uint8_t mask = (uint8_t)(1u << (unsigned)bit);
            dev->halted = halt != 0u ? (uint8_t)(dev->halted | mask)
                                     : (uint8_t)(dev->halted & (uint8_t)~mask);
            dev->drv->ep_halt(dev->ctx, (uint8_t)s->index, halt);
        }
        return 1;
    }
    default:
        return 0; /* SYNCH_FRAME is for isochronous endpoints only */
    }
}

static int class_request(usb_dev_t *dev, const setup_t *s) {
    if (RT_RECIPIENT(s->bm) != TO_INTERFACE || s->index != USB_IF_COMM ||
        dev->state != USB_STATE_CONFIGURED) {
        return 0;
    }
    switch (s->request) {
    case CDC_SET_LINE_CODING:
        if ((s->bm & RT_IN) != 0u || s->value != 0u || s->length != LINE_CODING_LEN) {
            return 0;
        }
        dev->ep0 = USB_EP0_DATA_OUT;
        dev->out_len = 0u;
        dev->drv->ep0_receive(dev->ctx);
        return 1;
    case CDC_GET_LINE_CODING: {
        if (s->value != 0u) {
            return 0;
        }
        const uint32_t r = dev->line.rate;
        dev->reply[0] = (uint8_t)r;
        dev->reply[1] = (uint8_t)(r >> 8);
        dev->reply[2] = (uint8_t)(r >> 16);
        dev->reply[3] = (uint8_t)(r >> 24);
        dev->reply[4] = dev->line.stop_bits;
        dev->reply[5] = dev->line.parity;
        dev->reply[6] = dev->line.data_bits;
        return reply_in(dev, s, dev->reply, LINE_CODING_LEN);
    }
    case CDC_SET_CONTROL_LINE_STATE: /* Table 18: bit 0 DTR, bit 1 RTS, the rest reserved */
        if ((s->value & ~3u) != 0u || !no_data(dev, s)) {
            return 0;
        }
        if (usb_cdc_port_open(dev) && (s->value & 1u) == 0u) {
            dev->port_closes++; /* the program closed the port: its frames are stale now */
        }
        dev->control_lines = s->value;
        return 1;
    case CDC_SEND_BREAK: /* the board has no line to break: the duration is only recorded */
        if (!no_data(dev, s)) {
            return 0;
        }
        dev->break_ms = s->value;
        return 1;
    default:
        return 0;
    }
}

static int line_coding_valid(const uint8_t *b) {
    const uint8_t bits = b[6];
    return b[4] <= 2u && b[5] <= 4u && ((bits >= 5u && bits <= 8u) || bits == 16u);
}

static void finish_out_stage(usb_dev_t *dev) {
    const setup_t s = parse(dev->setup);
    if (RT_TYPE(s.bm) == TYPE_CLASS && s.request == CDC_SET_LINE_CODING) {
        const uint8_t *b = dev->out_buf;
        if (!line_coding_valid(b)) {
            stall(dev);
            return;
        }
        dev->line.rate = (uint32_t)b[0] | ((uint32_t)b[1] << 8) | ((uint32_t)b[2] << 16) |
                         ((uint32_t)b[3] << 24);
        dev->line.stop_bits = b[4];
        dev->line.parity = b[5];
        dev->line.data_bits = b[6];
        status_in(dev);
        return;
    }
    stall(dev);
}

static void reset_state(usb_dev_t *dev) {
    dev->state = USB_STATE_DEFAULT;
    dev->state_before_suspend = USB_STATE_DEFAULT;
    dev->address = 0u;
    dev->pending_address = 0u;
    dev->configuration = 0u;
    dev->ep0 = USB_EP0_IDLE;
    dev->in_left = 0u;
    dev->in_zlp = 0u;
    dev->out_len = 0u;
    dev->halted = 0u;
    dev->control_lines = 0u;
    /* The UART build's setting, so a host that sets nothing sees the same line. */
    dev->line.rate = 921600u;
    dev->line.stop_bits = 0u;
    dev->line.parity = 0u;
    dev->line.data_bits = 8u;
}

void usb_dev_init(usb_dev_t *dev, const usb_driver_t *drv, void *ctx, const uint8_t uid[12]) {
    memset(dev, 0, sizeof *dev);
    dev->drv = drv;
    dev->ctx = ctx;
    usb_desc_serial(dev->serial, uid);
    reset_state(dev);
}

void usb_dev_bus_reset(usb_dev_t *dev) {
    reset_state(dev);
    dev->drv->configure(dev->ctx, 0u);
    dev->drv->set_address(dev->ctx, 0u);
}

void usb_dev_suspend(usb_dev_t *dev) {
    if (dev->state != USB_STATE_SUSPENDED) {
        dev->state_before_suspend = dev->state;
        dev->state = USB_STATE_SUSPENDED;
    }
}

void usb_dev_resume(usb_dev_t *dev) {
    if (dev->state == USB_STATE_SUSPENDED) {
        dev->state = dev->state_before_suspend;
    }
}

void usb_dev_setup(usb_dev_t *dev, const uint8_t packet[8]) {
    usb_dev_resume(dev); /* a SETUP is bus activity: the device is no longer suspended */
    memcpy(dev->setup, packet, 8u);
    /* A SETUP always starts a new transfer, whatever the previous one was doing (§8.5.3). */
    dev->ep0 = USB_EP0_IDLE;
    dev->in_left = 0u;
    dev->in_zlp = 0u;
    if ((dev->pending_address & 0x80u) != 0u) {
        dev->pending_address = 0u; /* the SET_ADDRESS's status stage never completed */
    }
    const setup_t s = parse(packet);
    int ok = 0;
    if (RT_TYPE(s.bm) == TYPE_STANDARD) {
        switch (RT_RECIPIENT(s.bm)) {
        case TO_DEVICE:
            ok = device_request(dev, &s);
            break;
        case TO_INTERFACE:
            ok = interface_request(dev, &s);
            break;
        case TO_ENDPOINT:
            ok = endpoint_request(dev, &s);
            break;
        default:
            break;
        }
    } else if (RT_TYPE(s.bm) == TYPE_CLASS) {
        ok = class_request(dev, &s);
    }
    if (!ok) {
        stall(dev);
    }
}

void usb_dev_ep0_in_done(usb_dev_t *dev) {
    if (dev->ep0 == USB_EP0_DATA_IN) {
        send_next(dev);
    } else if (dev->ep0 == USB_EP0_STATUS_IN) {
        dev->ep0 = USB_EP0_IDLE;
        if ((dev->pending_address & 0x80u) != 0u) {
            /* The address takes effect only now, after the status stage (§9.4.6). */
            const uint8_t address = (uint8_t)(dev->pending_address & 0x7Fu);
            dev->pending_address = 0u;
            dev->address = address;
            if (dev->drv->address_before_status == 0u) {
                dev->drv->set_address(dev->ctx, address);
            }
            dev->state = address != 0u ? USB_STATE_ADDRESS : USB_STATE_DEFAULT;
        }
    }
}

void usb_dev_ep0_out(usb_dev_t *dev, const uint8_t *data, uint32_t len) {
    switch (dev->ep0) {
    case USB_EP0_DATA_OUT: {
        const uint32_t want = (uint32_t)(dev->setup[6] | (dev->setup[7] << 8));
        if (len > want - dev->out_len || len > USB_EP0_SIZE) {
            stall(dev); /* more than wLength announced */
            return;
        }
        memcpy(dev->out_buf + dev->out_len, data, len);
        dev->out_len = (uint8_t)(dev->out_len + len);
        if (dev->out_len == want) {
            finish_out_stage(dev);
        } else if (len < USB_EP0_SIZE) {
            stall(dev); /* a short packet ended the stage before wLength */
        } else {
            dev->drv->ep0_receive(dev->ctx);
        }
        return;
    }
    case USB_EP0_STATUS_OUT:
        if (len != 0u) {
            stall(dev);
            return;
        }
        dev->ep0 = USB_EP0_IDLE;
        return;
    case USB_EP0_DATA_IN:
        /* The host may end a read early with its status packet. */
        dev->ep0 = USB_EP0_IDLE;
        dev->in_left = 0u;
        dev->in_zlp = 0u;
        return;
    default:
        return;
    }
}

int usb_cdc_port_open(const usb_dev_t *dev) {
    return dev->state == USB_STATE_CONFIGURED && (dev->control_lines & 1u) != 0u;
}
