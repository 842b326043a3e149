/* Descriptors of the SpectraTac USB device: one CDC-ACM function (a communication interface
 * with an interrupt IN notification endpoint and a data interface with bulk OUT/IN), grouped by
 * an Interface Association Descriptor so that hosts bind one driver (Linux cdc_acm) to both.
 * Full speed only. All constant except the serial number string, built from the chip UID. */
#ifndef USB_DESC_H
#define USB_DESC_H

#include <stdint.h>

#define USB_EP0_SIZE 64u             /* bMaxPacketSize0 (USB 2.0 §5.5.3: 8/16/32/64 at FS) */
#define USB_DATA_SIZE 64u            /* bulk wMaxPacketSize, the FS maximum (USB 2.0 §5.8.3) */
#define USB_NOTIFY_SIZE 16u          /* interrupt IN: SERIAL_STATE is 10 bytes (PSTN §6.5.4) */
#define USB_EP_DATA_OUT 0x01u        /* endpoint addresses: bit 7 = IN (USB 2.0 Table 9-13) */
#define USB_EP_DATA_IN 0x81u
#define USB_EP_NOTIFY_IN 0x82u
#define USB_NOTIFY_INTERVAL_MS 16u   /* bInterval, frames of 1 ms at full speed */
#define USB_IF_COMM 0u
#define USB_IF_DATA 1u
#define USB_IF_COUNT 2u
#define USB_CONFIG_VALUE 1u          /* bConfigurationValue of the only configuration */
#define USB_LANGID_EN_US 0x0409u

/* pid.codes test identifiers (VID 0x1209, PID 0x0001): for development only; a product needs
 * its own PID (README "USB"). */
#define USB_VID 0x1209u
#define USB_PID 0x0001u

enum {
    USB_STR_LANGIDS = 0,
    USB_STR_MANUFACTURER = 1,
    USB_STR_PRODUCT = 2,
    USB_STR_SERIAL = 3,
    USB_STR_COUNT = 4
};

#define USB_DEVICE_DESC_LEN 18u
#define USB_CONFIG_DESC_LEN 75u
/* 24 hex digits of the 96-bit UID in UTF-16LE after the 2-byte header. */
#define USB_SERIAL_DESC_LEN (2u + 2u * 24u)

extern const uint8_t k_usb_device_desc[USB_DEVICE_DESC_LEN];
extern const uint8_t k_usb_config_desc[USB_CONFIG_DESC_LEN];

/* Fill a string descriptor for the serial number: the UID bytes as upper-case hex, in order. */
void usb_desc_serial(uint8_t out[USB_SERIAL_DESC_LEN], const uint8_t uid[12]);

/* The string descriptor `index` (USB_STR_*), or 0 with *len untouched when there is none.
 * `serial` is the descriptor built by usb_desc_serial. */
const uint8_t *usb_desc_string(uint8_t index, const uint8_t *serial, uint16_t *len);

#endif /* USB_DESC_H */
