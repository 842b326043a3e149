#include "fake_udc.h"

#include <string.h>

static void f_send(void *ctx, const uint8_t *data, uint32_t len) {
    fake_udc_t *f = ctx;
    f->sends++;
    if (f->queued < FAKE_MAX_PACKETS && len <= USB_EP0_SIZE) {
        if (len > 0u) {
            memcpy(f->packets[f->queued], data, len);
        }
        f->packet_len[f->queued] = len;
        f->queued++;
    }
}

static void f_receive(void *ctx) {
    ((fake_udc_t *)ctx)->receives++;
}

static void f_stall(void *ctx) {
    ((fake_udc_t *)ctx)->stalls++;
}

static void f_set_address(void *ctx, uint8_t address) {
    fake_udc_t *f = ctx;
    f->hw_address = address;
    f->set_address_calls++;
}

static void f_configure(void *ctx, uint8_t on) {
    fake_udc_t *f = ctx;
    f->configured = on;
    f->configure_calls++;
}

static void f_ep_halt(void *ctx, uint8_t ep, uint8_t halt) {
    fake_udc_t *f = ctx;
    f->halt_ep = ep;
    f->halt_value = halt;
    f->halt_calls++;
}

const usb_driver_t g_fake_driver = {f_send, f_receive, f_stall, f_set_address, f_configure,
                                    f_ep_halt, 0u};
const usb_driver_t g_fake_driver_early = {f_send, f_receive, f_stall, f_set_address,
                                          f_configure, f_ep_halt, 1u};

void fake_init(fake_udc_t *f) {
    memset(f, 0, sizeof *f);
    f->hw_address = -1;
    f->configured = -1;
}

/* Take the oldest queued IN packet (the host's IN token), then tell the core it went out. */
static int pop_packet(usb_dev_t *dev, fake_udc_t *f, uint8_t *dst, uint32_t *len) {
    if (f->queued == 0u) {
        return 0;
    }
    *len = f->packet_len[0];
    if (dst != NULL) {
        memcpy(dst, f->packets[0], *len);
    }
    f->queued--;
    memmove(f->packets[0], f->packets[1], f->queued * sizeof f->packets[0]);
    memmove(&f->packet_len[0], &f->packet_len[1], f->queued * sizeof f->packet_len[0]);
    usb_dev_ep0_in_done(dev);
    return 1;
}

xfer_t control(usb_dev_t *dev, fake_udc_t *f, uint8_t bm, uint8_t request, uint16_t value,
               uint16_t index, uint16_t length, const uint8_t *out) {
    xfer_t x;
    memset(&x, 0, sizeof x);
    const uint8_t setup[8] = {bm,
                              request,
                              (uint8_t)value,
                              (uint8_t)(value >> 8),
                              (uint8_t)index,
                              (uint8_t)(index >> 8),
                              (uint8_t)length,
                              (uint8_t)(length >> 8)};
    const uint32_t stalls = f->stalls;
    f->queued = 0u;
    usb_dev_setup(dev, setup);
    if (f->stalls != stalls) {
        x.stalled = 1;
        return x;
    }
    if ((bm & 0x80u) != 0u && length > 0u) {
        /* IN data stage: read packets until a short one (a zero-length one included). */
        for (uint32_t guard = 0; guard < 64u; guard++) {
            uint32_t len = 0u;
            if (x.len + USB_EP0_SIZE > sizeof x.data || !pop_packet(dev, f, x.data + x.len, &len)) {
                break;
            }
            x.len += len;
            x.packets++;
            if (len < USB_EP0_SIZE) {
                x.zlp = len == 0u;
                break;
            }
            if (x.len == length) {
                break; /* wLength reached on a packet boundary: the stage is over */
            }
        }
        usb_dev_ep0_out(dev, NULL, 0u); /* status stage: the host's zero-length OUT */
    } else {
        if ((bm & 0x80u) == 0u && length > 0u) {
            for (uint32_t sent = 0; sent < length;) {
                const uint32_t n = length - sent < USB_EP0_SIZE ? length - sent : USB_EP0_SIZE;
                usb_dev_ep0_out(dev, out + sent, n);
                sent += n;
                if (f->stalls != stalls) {
                    break;
                }
            }
        }
        uint32_t len = 0u;
        if (f->stalls == stalls && !pop_packet(dev, f, NULL, &len)) {
            x.stalled = 1; /* no status packet came: treat as a failed transfer */
        }
    }
    x.stalled = x.stalled || f->stalls != stalls;
    return x;
}

void enumerate(usb_dev_t *dev, fake_udc_t *f, const usb_driver_t *drv, uint8_t address) {
    static const uint8_t uid[12] = {0x12, 0x34, 0x56, 0x78, 0x9A, 0xBC,
                                    0xDE, 0xF0, 0x01, 0x23, 0x45, 0x67};
    fake_init(f);
    usb_dev_init(dev, drv, f, uid);
    usb_dev_bus_reset(dev);
    (void)control(dev, f, 0x80u, 6u, 0x0100u, 0u, 64u, NULL);
    usb_dev_bus_reset(dev);
    (void)control(dev, f, 0x00u, 5u, address, 0u, 0u, NULL);
    (void)control(dev, f, 0x00u, 9u, 1u, 0u, 0u, NULL);
}
