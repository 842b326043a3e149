/* Descriptor bytes, field by field. References: USB 2.0 §9.6 (Tables 9-8 device, 9-10
 * configuration, 9-12 interface, 9-13 endpoint, 9-15/9-16 strings), the Interface Association
 * Descriptor ECN (Table 9-Z), CDC 1.2 §5.2.3 (Table 15 header, Table 16 union) and PSTN 1.2
 * §5.3 (Table 3 call management, Table 4 abstract control management). */
#include "usb_desc.h"

#define LO(v) (uint8_t)((v) & 0xFFu)
#define HI(v) (uint8_t)(((v) >> 8) & 0xFFu)

#define DESC_DEVICE 0x01u
#define DESC_CONFIGURATION 0x02u
#define DESC_STRING 0x03u
#define DESC_INTERFACE 0x04u
#define DESC_ENDPOINT 0x05u
#define DESC_IAD 0x0Bu
#define DESC_CS_INTERFACE 0x24u /* CDC 1.2 Table 12 */

#define CLASS_CDC 0x02u         /* CDC 1.2 Table 2 (communication interface class) */
#define SUBCLASS_ACM 0x02u      /* CDC 1.2 Table 4 */
#define PROTOCOL_NONE 0x00u     /* CDC 1.2 Table 5: no AT command set, so modem managers
                                 * leave the port alone */
#define CLASS_CDC_DATA 0x0Au    /* CDC 1.2 Table 6 */
#define ATTR_BULK 0x02u
#define ATTR_INTERRUPT 0x03u

const uint8_t k_usb_device_desc[USB_DEVICE_DESC_LEN] = {
    18u, DESC_DEVICE,
    0x00u, 0x02u,             /* bcdUSB 2.00 */
    0xEFu, 0x02u, 0x01u,      /* miscellaneous / common class / IAD: the IAD ECN's class codes */
    (uint8_t)USB_EP0_SIZE,
    LO(USB_VID), HI(USB_VID), LO(USB_PID), HI(USB_PID),
    0x00u, 0x01u,             /* bcdDevice 1.00 */
    USB_STR_MANUFACTURER, USB_STR_PRODUCT, USB_STR_SERIAL,
    1u,                       /* bNumConfigurations */
};

const uint8_t k_usb_config_desc[USB_CONFIG_DESC_LEN] = {
    /* configuration: bus powered; 250 mA covers nine LED channels at 20 mA, MCU and sensors */
    9u, DESC_CONFIGURATION, LO(USB_CONFIG_DESC_LEN), HI(USB_CONFIG_DESC_LEN), USB_IF_COUNT,
    USB_CONFIG_VALUE, 0u, 0x80u, 125u,
    /* interface association: both interfaces are one CDC-ACM function */
    8u, DESC_IAD, USB_IF_COMM, USB_IF_COUNT, CLASS_CDC, SUBCLASS_ACM, PROTOCOL_NONE, 0u,
    /* communication interface: one endpoint (notifications) */
    9u, DESC_INTERFACE, USB_IF_COMM, 0u, 1u, CLASS_CDC, SUBCLASS_ACM, PROTOCOL_NONE, 0u,
    5u, DESC_CS_INTERFACE, 0x00u, 0x20u, 0x01u,   /* header, bcdCDC 1.20 */
    5u, DESC_CS_INTERFACE, 0x01u, 0x00u, USB_IF_DATA, /* call management: none, data if 1 */
    4u, DESC_CS_INTERFACE, 0x02u, 0x06u,  /* ACM: line coding + line state, SEND_BREAK */
    5u, DESC_CS_INTERFACE, 0x06u, USB_IF_COMM, USB_IF_DATA, /* union: control 0, subordinate 1 */
    7u, DESC_ENDPOINT, USB_EP_NOTIFY_IN, ATTR_INTERRUPT, LO(USB_NOTIFY_SIZE), HI(USB_NOTIFY_SIZE),
    USB_NOTIFY_INTERVAL_MS,
    /* data interface: bulk OUT and IN */
    9u, DESC_INTERFACE, USB_IF_DATA, 0u, 2u, CLASS_CDC_DATA, 0u, 0u, 0u,
    7u, DESC_ENDPOINT, USB_EP_DATA_OUT, ATTR_BULK, LO(USB_DATA_SIZE), HI(USB_DATA_SIZE), 0u,
    7u, DESC_ENDPOINT, USB_EP_DATA_IN, ATTR_BULK, LO(USB_DATA_SIZE), HI(USB_DATA_SIZE), 0u,
};

/* UTF-16LE of ASCII text: each character followed by a zero byte. */
#define U(c) (uint8_t)(c), 0u

static const uint8_t k_langids[4] = {4u, DESC_STRING, LO(USB_LANGID_EN_US), HI(USB_LANGID_EN_US)};
static const uint8_t k_manufacturer[2u + 2u * 10u] = {
    22u, DESC_STRING, U('S'), U('p'), U('e'), U('c'), U('t'), U('r'), U('a'), U('T'), U('a'),
    U('c'),
};
static const uint8_t k_product[2u + 2u * 23u] = {
    48u, DESC_STRING, U('S'), U('p'), U('e'), U('c'), U('t'), U('r'), U('a'), U('T'), U('a'),
    U('c'), U(' '), U('s'), U('e'), U('n'), U('s'), U('o'), U('r'), U(' '), U('b'), U('o'),
    U('a'), U('r'), U('d'),
};

void usb_desc_serial(uint8_t out[USB_SERIAL_DESC_LEN], const uint8_t uid[12]) {
    static const char hex[] = "0123456789ABCDEF";
    out[0] = (uint8_t)USB_SERIAL_DESC_LEN;
    out[1] = DESC_STRING;
    for (uint32_t i = 0; i < 12u; i++) {
        out[2u + 4u * i] = (uint8_t)hex[uid[i] >> 4];
        out[3u + 4u * i] = 0u;
        out[4u + 4u * i] = (uint8_t)hex[uid[i] & 0x0Fu];
        out[5u + 4u * i] = 0u;
    }
}

const uint8_t *usb_desc_string(uint8_t index, const uint8_t *serial, uint16_t *len) {
    const uint8_t *d = 0;
    switch (index) {
    case USB_STR_LANGIDS:
        d = k_langids;
        break;
    case USB_STR_MANUFACTURER:
        d = k_manufacturer;
        break;
    case USB_STR_PRODUCT:
        d = k_product;
        break;
    case USB_STR_SERIAL:
        d = serial;
        break;
    default:
        return 0;
    }
    *len = d[0];
    return d;
}
