/* The USB device core against the USB 2.0 chapter-9 and CDC/PSTN 1.2 rules, through a fake
 * controller. `usb_tests --list` names the tests, `usb_tests NAME` runs one,
 * `usb_tests --descriptors` prints the descriptor bytes for the independent parser
 * (tests/firmware/test_usb_descriptors.py). */
#include <stdio.h>
#include <string.h>

#include "check.h"
#include "fake_udc.h"
#include "usb_cdc_io.h"
#include "usb_desc.h"
#include "usb_dev.h"


static const uint8_t k_uid[12] = {0x12, 0x34, 0x56, 0x78, 0x9A, 0xBC,
                                  0xDE, 0xF0, 0x01, 0x23, 0x45, 0x67};

/* bmRequestType values used below. */
#define D2H_DEV 0x80u
#define H2D_DEV 0x00u
#define D2H_IF 0x81u
#define H2D_IF 0x01u
#define D2H_EP 0x82u
#define H2D_EP 0x02u
#define D2H_CLASS_IF 0xA1u
#define H2D_CLASS_IF 0x21u

static void fresh(usb_dev_t *dev, fake_udc_t *f) {
    fake_init(f);
    usb_dev_init(dev, &g_fake_driver, f, k_uid);
    usb_dev_bus_reset(dev);
}

/* Bring the device to a state: 0 Default, 1 Address (7), 2 Configured. */
static void to_state(usb_dev_t *dev, fake_udc_t *f, int state) {
    fresh(dev, f);
    if (state >= 1) {
        (void)control(dev, f, H2D_DEV, 5u, 7u, 0u, 0u, NULL);
    }
    if (state >= 2) {
        (void)control(dev, f, H2D_DEV, 9u, 1u, 0u, 0u, NULL);
    }
}

/* One standard or class request in one state, and what the rules say must happen. */
typedef struct {
    const char *what;
    int state;
    uint8_t bm, request;
    uint16_t value, index, length;
    int stall;
    int reply_len; /* data-stage bytes expected when not stalled */
} req_case_t;

static const req_case_t k_cases[] = {
    /* GET_STATUS (§9.4.5): two bytes for device, interface, endpoint */
    {"status device", 1, D2H_DEV, 0, 0, 0, 2, 0, 2},
    {"status device wLength 1", 1, D2H_DEV, 0, 0, 0, 1, 1, 0},
    {"status device wValue", 1, D2H_DEV, 0, 1, 0, 2, 1, 0},
    {"status interface configured", 2, D2H_IF, 0, 0, 1, 2, 0, 2},
    {"status interface 2 missing", 2, D2H_IF, 0, 0, 2, 2, 1, 0},
    {"status interface in address state", 1, D2H_IF, 0, 0, 0, 2, 1, 0},
    {"status ep0", 1, D2H_EP, 0, 0, 0x80, 2, 0, 2},
    {"status ep 0x81 configured", 2, D2H_EP, 0, 0, 0x81, 2, 0, 2},
    {"status ep 0x81 in address state", 1, D2H_EP, 0, 0, 0x81, 2, 1, 0},
    {"status ep 0x83 missing", 2, D2H_EP, 0, 0, 0x83, 2, 1, 0},
    /* CLEAR/SET_FEATURE (§9.4.1, §9.4.9) */
    {"set remote wakeup: not offered", 2, H2D_DEV, 3, 1, 0, 0, 1, 0},
    {"set test mode: high speed only", 2, H2D_DEV, 3, 2, 0, 0, 1, 0},
    {"clear remote wakeup", 2, H2D_DEV, 1, 1, 0, 0, 1, 0},
    {"interface feature", 2, H2D_IF, 3, 0, 0, 0, 1, 0},
    {"halt ep 0x01", 2, H2D_EP, 3, 0, 0x01, 0, 0, 0},
    {"halt ep 0x82", 2, H2D_EP, 3, 0, 0x82, 0, 0, 0},
    {"halt ep0 refused", 2, H2D_EP, 3, 0, 0x00, 0, 1, 0},
    {"clear halt ep0", 2, H2D_EP, 1, 0, 0x00, 0, 0, 0},
    {"halt unknown feature", 2, H2D_EP, 3, 5, 0x81, 0, 1, 0},
    {"halt ep 0x02 missing", 2, H2D_EP, 3, 0, 0x02, 0, 1, 0},
    {"halt wLength 2", 2, H2D_EP, 3, 0, 0x81, 2, 1, 0},
    /* SET_ADDRESS (§9.4.6) */
    {"address 128 too big", 0, H2D_DEV, 5, 128, 0, 0, 1, 0},
    {"address with wIndex", 0, H2D_DEV, 5, 3, 1, 0, 1, 0},
    {"address in configured state", 2, H2D_DEV, 5, 3, 0, 0, 1, 0},
    {"address as IN request", 0, D2H_DEV, 5, 3, 0, 0, 1, 0},
    /* GET_DESCRIPTOR (§9.4.3) */
    {"device descriptor", 0, D2H_DEV, 6, 0x0100, 0, 64, 0, 18},
    {"device descriptor first 8 bytes", 0, D2H_DEV, 6, 0x0100, 0, 8, 0, 8},
    {"device descriptor index 1", 0, D2H_DEV, 6, 0x0101, 0, 18, 1, 0},
    {"configuration header only", 1, D2H_DEV, 6, 0x0200, 0, 9, 0, 9},
    {"configuration all", 1, D2H_DEV, 6, 0x0200, 0, 0xFF, 0, 75},
    {"configuration index 1", 1, D2H_DEV, 6, 0x0201, 0, 0xFF, 1, 0},
    {"language ids", 1, D2H_DEV, 6, 0x0300, 0, 0xFF, 0, 4},
    {"manufacturer", 1, D2H_DEV, 6, 0x0301, 0x0409, 0xFF, 0, 22},
    {"product", 1, D2H_DEV, 6, 0x0302, 0x0409, 0xFF, 0, 48},
    {"serial", 1, D2H_DEV, 6, 0x0303, 0x0409, 0xFF, 0, 50},
    {"string in German", 1, D2H_DEV, 6, 0x0301, 0x0407, 0xFF, 1, 0},
    {"string 4 missing", 1, D2H_DEV, 6, 0x0304, 0x0409, 0xFF, 1, 0},
    {"device qualifier: full speed only", 1, D2H_DEV, 6, 0x0600, 0, 10, 1, 0},
    {"other speed configuration", 1, D2H_DEV, 6, 0x0700, 0, 0xFF, 1, 0},
    {"interface-recipient descriptor", 2, D2H_IF, 6, 0x2100, 0, 9, 1, 0},
    {"get descriptor as OUT", 1, H2D_DEV, 6, 0x0100, 0, 18, 1, 0},
    {"set descriptor", 1, H2D_DEV, 7, 0x0100, 0, 18, 1, 0},
    /* GET/SET_CONFIGURATION (§9.4.2, §9.4.7) */
    {"get configuration address state", 1, D2H_DEV, 8, 0, 0, 1, 0, 1},
    {"get configuration default state", 0, D2H_DEV, 8, 0, 0, 1, 1, 0},
    {"get configuration wLength 2", 1, D2H_DEV, 8, 0, 0, 2, 1, 0},
    {"set configuration 2 missing", 1, H2D_DEV, 9, 2, 0, 0, 1, 0},
    {"set configuration default state", 0, H2D_DEV, 9, 1, 0, 0, 1, 0},
    {"set configuration high byte", 1, H2D_DEV, 9, 0x0101, 0, 0, 1, 0},
    {"set configuration 0", 2, H2D_DEV, 9, 0, 0, 0, 0, 0},
    /* GET/SET_INTERFACE (§9.4.4, §9.4.10) */
    {"get interface", 2, D2H_IF, 10, 0, 1, 1, 0, 1},
    {"get interface address state", 1, D2H_IF, 10, 0, 0, 1, 1, 0},
    {"set interface alt 0", 2, H2D_IF, 11, 0, 1, 0, 0, 0},
    {"set interface alt 1 missing", 2, H2D_IF, 11, 1, 1, 0, 1, 0},
    {"synch frame: no isochronous endpoint", 2, D2H_EP, 12, 0, 0x81, 2, 1, 0},
    /* CDC class requests (PSTN 1.2 §6.3) */
    {"get line coding", 2, D2H_CLASS_IF, 0x21, 0, 0, 7, 0, 7},
    {"get line coding address state", 1, D2H_CLASS_IF, 0x21, 0, 0, 7, 1, 0},
    {"get line coding data interface", 2, D2H_CLASS_IF, 0x21, 0, 1, 7, 1, 0},
    {"line state DTR+RTS", 2, H2D_CLASS_IF, 0x22, 3, 0, 0, 0, 0},
    {"line state reserved bit", 2, H2D_CLASS_IF, 0x22, 4, 0, 0, 1, 0},
    {"send break", 2, H2D_CLASS_IF, 0x23, 100, 0, 0, 0, 0},
    {"set line coding wLength 6", 2, H2D_CLASS_IF, 0x20, 0, 0, 6, 1, 0},
    {"unsupported class request", 2, H2D_CLASS_IF, 0x02, 0, 0, 0, 1, 0},
    {"class request to device", 2, 0x21u & ~1u, 0x22, 1, 0, 0, 1, 0},
    {"vendor request", 2, 0x40u, 0x01, 0, 0, 0, 1, 0},
    {"reserved type", 2, 0x60u, 0x01, 0, 0, 0, 1, 0},
    {"reserved recipient", 2, 0x83u, 0x00, 0, 0, 2, 1, 0},
};

TEST(usb_request_table) {
    static const uint8_t zeros[8] = {0};
    for (size_t i = 0; i < sizeof k_cases / sizeof k_cases[0]; i++) {
        const req_case_t *c = &k_cases[i];
        usb_dev_t dev;
        fake_udc_t f;
        to_state(&dev, &f, c->state);
        const xfer_t x = control(&dev, &f, c->bm, c->request, c->value, c->index, c->length,
                                 zeros);
        if (x.stalled != c->stall || (!x.stalled && (int)x.len != c->reply_len)) {
            printf("case '%s': stalled %d (want %d), %u bytes (want %d)\n", c->what, x.stalled,
                   c->stall, (unsigned)x.len, c->reply_len);
            CHECK(0);
        }
        CHECK_EQ(dev.ep0, x.stalled ? USB_EP0_STALLED : USB_EP0_IDLE);
    }
}

TEST(usb_stall_ends_at_next_setup) {
    usb_dev_t dev;
    fake_udc_t f;
    to_state(&dev, &f, 1);
    CHECK(control(&dev, &f, D2H_DEV, 6, 0x0600, 0, 10, NULL).stalled);
    CHECK_EQ(dev.stalls, 1);
    const xfer_t x = control(&dev, &f, D2H_DEV, 6, 0x0100, 0, 18, NULL);
    CHECK(!x.stalled);
    CHECK_EQ(x.len, 18);
}

TEST(usb_device_descriptor_bytes) {
    usb_dev_t dev;
    fake_udc_t f;
    fresh(&dev, &f);
    const xfer_t x = control(&dev, &f, D2H_DEV, 6, 0x0100, 0, 0x40, NULL);
    CHECK_EQ(x.len, 18);
    CHECK(memcmp(x.data, k_usb_device_desc, 18) == 0);
    CHECK_EQ(x.data[7], USB_EP0_SIZE); /* bMaxPacketSize0 */
    CHECK_EQ(x.packets, 1);
    CHECK(!x.zlp);
}

TEST(usb_multi_packet_in_and_truncation) {
    usb_dev_t dev;
    fake_udc_t f;
    to_state(&dev, &f, 1);
    /* 75 bytes in packets of 64 + 11; the short packet ends the stage, no ZLP. */
    xfer_t x = control(&dev, &f, D2H_DEV, 6, 0x0200, 0, 0xFF, NULL);
    CHECK_EQ(x.len, USB_CONFIG_DESC_LEN);
    CHECK_EQ(x.packets, 2);
    CHECK(!x.zlp);
    CHECK(memcmp(x.data, k_usb_config_desc, USB_CONFIG_DESC_LEN) == 0);
    /* wLength 64: exactly one full packet and nothing after it (wLength reached). */
    x = control(&dev, &f, D2H_DEV, 6, 0x0200, 0, 64, NULL);
    CHECK_EQ(x.len, 64);
    CHECK_EQ(x.packets, 1);
    CHECK_EQ(f.queued, 0);
    CHECK(memcmp(x.data, k_usb_config_desc, 64) == 0);
    /* wLength 70: 64 + 6, truncated. */
    x = control(&dev, &f, D2H_DEV, 6, 0x0200, 0, 70, NULL);
    CHECK_EQ(x.len, 70);
    CHECK_EQ(x.packets, 2);
    /* The header alone tells the host wTotalLength. */
    x = control(&dev, &f, D2H_DEV, 6, 0x0200, 0, 9, NULL);
    CHECK_EQ(x.len, 9);
    CHECK_EQ(x.data[2] | (x.data[3] << 8), USB_CONFIG_DESC_LEN);
}

TEST(usb_zlp_rule) {
    /* {answer length, wLength, stage length, zlp} */
    static const uint32_t cases[][4] = {
        {18, 64, 18, 0},   {18, 8, 8, 0},      {64, 64, 64, 0},  {64, 255, 64, 1},
        {128, 255, 128, 1}, {128, 128, 128, 0}, {75, 255, 75, 0}, {128, 100, 100, 0},
        {0, 10, 0, 1},     {192, 65535, 192, 1}, {7, 0, 0, 0},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        uint8_t zlp = 9u;
        const uint32_t n = usb_ep0_data_stage(cases[i][0], (uint16_t)cases[i][1], &zlp);
        CHECK_EQ(n, cases[i][2]);
        CHECK_EQ(zlp, cases[i][3]);
    }
}

TEST(usb_short_answer_has_no_zlp) {
    /* No answer of this device is a non-empty multiple of 64 bytes shorter than wLength, so
     * the ZLP case is covered by usb_zlp_rule; here a short answer to a long wLength must end
     * with its one short packet and nothing after it. */
    usb_dev_t dev;
    fake_udc_t f;
    to_state(&dev, &f, 2);
    const xfer_t x = control(&dev, &f, D2H_CLASS_IF, 0x21, 0, 0, 64, NULL);
    CHECK_EQ(x.len, 7);
    CHECK_EQ(x.packets, 1);
    CHECK(!x.zlp);
    CHECK_EQ(f.queued, 0);
    CHECK_EQ(dev.ep0, USB_EP0_IDLE);
}

TEST(usb_address_applied_after_status_stage) {
    usb_dev_t dev;
    fake_udc_t f;
    fresh(&dev, &f);
    CHECK_EQ(f.hw_address, 0); /* bus reset cleared it */
    const uint8_t setup[8] = {H2D_DEV, 5, 42, 0, 0, 0, 0, 0};
    usb_dev_setup(&dev, setup);
    /* Status stage queued, not yet sent: still Default at address 0. */
    CHECK_EQ(f.queued, 1);
    CHECK_EQ(f.packet_len[0], 0);
    CHECK_EQ(dev.state, USB_STATE_DEFAULT);
    CHECK_EQ(dev.address, 0);
    CHECK_EQ(f.hw_address, 0);
    usb_dev_ep0_in_done(&dev);
    CHECK_EQ(dev.state, USB_STATE_ADDRESS);
    CHECK_EQ(dev.address, 42);
    CHECK_EQ(f.hw_address, 42);
    /* Address 0 from the Address state goes back to Default (§9.4.6). */
    CHECK(!control(&dev, &f, H2D_DEV, 5, 0, 0, 0, NULL).stalled);
    CHECK_EQ(dev.state, USB_STATE_DEFAULT);
    CHECK_EQ(f.hw_address, 0);
}

TEST(usb_address_early_for_otg_cores) {
    usb_dev_t dev;
    fake_udc_t f;
    fake_init(&f);
    usb_dev_init(&dev, &g_fake_driver_early, &f, k_uid);
    usb_dev_bus_reset(&dev);
    const uint8_t setup[8] = {H2D_DEV, 5, 9, 0, 0, 0, 0, 0};
    usb_dev_setup(&dev, setup);
    CHECK_EQ(f.hw_address, 9);                 /* the controller has it before the status */
    CHECK_EQ(dev.state, USB_STATE_DEFAULT);    /* but the device state changes only after */
    const uint32_t calls = f.set_address_calls;
    usb_dev_ep0_in_done(&dev);
    CHECK_EQ(dev.state, USB_STATE_ADDRESS);
    CHECK_EQ(f.set_address_calls, calls);      /* not programmed twice */
}

TEST(usb_address_lost_when_status_never_completes) {
    usb_dev_t dev;
    fake_udc_t f;
    fresh(&dev, &f);
    const uint8_t set_address[8] = {H2D_DEV, 5, 11, 0, 0, 0, 0, 0};
    usb_dev_setup(&dev, set_address);
    /* The host gives up and sends another SETUP: no address was assigned. */
    CHECK(!control(&dev, &f, D2H_DEV, 6, 0x0100, 0, 18, NULL).stalled);
    usb_dev_ep0_in_done(&dev); /* a stray completion must not apply it either */
    CHECK_EQ(dev.state, USB_STATE_DEFAULT);
    CHECK_EQ(dev.address, 0);
    CHECK_EQ(f.hw_address, 0);
}

TEST(usb_configuration_set_and_cleared) {
    usb_dev_t dev;
    fake_udc_t f;
    to_state(&dev, &f, 1);
    xfer_t x = control(&dev, &f, D2H_DEV, 8, 0, 0, 1, NULL);
    CHECK_EQ(x.data[0], 0);
    CHECK(!control(&dev, &f, H2D_DEV, 9, 1, 0, 0, NULL).stalled);
    CHECK_EQ(dev.state, USB_STATE_CONFIGURED);
    CHECK_EQ(f.configured, 1);
    x = control(&dev, &f, D2H_DEV, 8, 0, 0, 1, NULL);
    CHECK_EQ(x.len, 1);
    CHECK_EQ(x.data[0], 1);
    /* A refused value leaves the configuration as it was. */
    CHECK(control(&dev, &f, H2D_DEV, 9, 3, 0, 0, NULL).stalled);
    CHECK_EQ(dev.state, USB_STATE_CONFIGURED);
    CHECK_EQ(f.configured, 1);
    CHECK(!control(&dev, &f, H2D_DEV, 9, 0, 0, 0, NULL).stalled);
    CHECK_EQ(dev.state, USB_STATE_ADDRESS);
    CHECK_EQ(f.configured, 0);
    x = control(&dev, &f, D2H_DEV, 8, 0, 0, 1, NULL);
    CHECK_EQ(x.data[0], 0);
    /* A bus reset returns to Default and deactivates the endpoints. */
    CHECK(!control(&dev, &f, H2D_DEV, 9, 1, 0, 0, NULL).stalled);
    usb_dev_bus_reset(&dev);
    CHECK_EQ(dev.state, USB_STATE_DEFAULT);
    CHECK_EQ(dev.configuration, 0);
    CHECK_EQ(f.configured, 0);
    CHECK_EQ(f.hw_address, 0);
}

TEST(usb_line_coding_round_trip) {
    usb_dev_t dev;
    fake_udc_t f;
    to_state(&dev, &f, 2);
    xfer_t x = control(&dev, &f, D2H_CLASS_IF, 0x21, 0, 0, 7, NULL);
    static const uint8_t initial[7] = {0x00, 0x10, 0x0E, 0x00, 0, 0, 8}; /* 921600 8N1 */
    CHECK(memcmp(x.data, initial, 7) == 0);
    static const uint8_t line[7] = {0x00, 0xC2, 0x01, 0x00, 2, 2, 7}; /* 115200 7E2 */
    CHECK(!control(&dev, &f, H2D_CLASS_IF, 0x20, 0, 0, 7, line).stalled);
    CHECK_EQ(dev.line.rate, 115200);
    CHECK_EQ(dev.line.stop_bits, 2);
    CHECK_EQ(dev.line.parity, 2);
    CHECK_EQ(dev.line.data_bits, 7);
    x = control(&dev, &f, D2H_CLASS_IF, 0x21, 0, 0, 7, NULL);
    CHECK_EQ(x.len, 7);
    CHECK(memcmp(x.data, line, 7) == 0);
    /* Values outside PSTN Table 17 are refused and change nothing. */
    static const uint8_t bad[3][7] = {
        {0x00, 0xC2, 0x01, 0x00, 3, 0, 8}, /* bCharFormat 3 */
        {0x00, 0xC2, 0x01, 0x00, 0, 5, 8}, /* bParityType 5 */
        {0x00, 0xC2, 0x01, 0x00, 0, 0, 9}, /* bDataBits 9 */
    };
    for (int i = 0; i < 3; i++) {
        CHECK(control(&dev, &f, H2D_CLASS_IF, 0x20, 0, 0, 7, bad[i]).stalled);
    }
    x = control(&dev, &f, D2H_CLASS_IF, 0x21, 0, 0, 7, NULL);
    CHECK(memcmp(x.data, line, 7) == 0);
    /* Truncated to wLength like any IN answer. */
    x = control(&dev, &f, D2H_CLASS_IF, 0x21, 0, 0, 4, NULL);
    CHECK_EQ(x.len, 4);
}

TEST(usb_line_coding_overlong_data_stage_stalls) {
    usb_dev_t dev;
    fake_udc_t f;
    to_state(&dev, &f, 2);
    const uint8_t setup[8] = {H2D_CLASS_IF, 0x20, 0, 0, 0, 0, 7, 0};
    usb_dev_setup(&dev, setup);
    CHECK_EQ(dev.ep0, USB_EP0_DATA_OUT);
    const uint8_t too_long[9] = {0, 0xC2, 1, 0, 0, 0, 8, 1, 2};
    usb_dev_ep0_out(&dev, too_long, 9);
    CHECK_EQ(dev.ep0, USB_EP0_STALLED);
    CHECK_EQ(dev.line.rate, 921600);
    /* A short packet before wLength ends the stage early: also an error. */
    usb_dev_setup(&dev, setup);
    usb_dev_ep0_out(&dev, too_long, 3);
    CHECK_EQ(dev.ep0, USB_EP0_STALLED);
}

TEST(usb_dtr_opens_the_port) {
    usb_dev_t dev;
    fake_udc_t f;
    to_state(&dev, &f, 2);
    CHECK(!usb_cdc_port_open(&dev));
    CHECK(!control(&dev, &f, H2D_CLASS_IF, 0x22, 1, 0, 0, NULL).stalled);
    CHECK(usb_cdc_port_open(&dev));
    CHECK(!control(&dev, &f, H2D_CLASS_IF, 0x22, 2, 0, 0, NULL).stalled); /* RTS alone */
    CHECK(!usb_cdc_port_open(&dev));
    CHECK(!control(&dev, &f, H2D_CLASS_IF, 0x22, 3, 0, 0, NULL).stalled);
    CHECK(usb_cdc_port_open(&dev));
    /* Suspend hides the port, resume restores it. */
    usb_dev_suspend(&dev);
    CHECK_EQ(dev.state, USB_STATE_SUSPENDED);
    CHECK(!usb_cdc_port_open(&dev));
    usb_dev_resume(&dev);
    CHECK_EQ(dev.state, USB_STATE_CONFIGURED);
    CHECK(usb_cdc_port_open(&dev));
    /* Deconfiguring or a bus reset closes it. */
    CHECK(!control(&dev, &f, H2D_DEV, 9, 0, 0, 0, NULL).stalled);
    CHECK(!usb_cdc_port_open(&dev));
    CHECK(!control(&dev, &f, H2D_DEV, 9, 1, 0, 0, NULL).stalled);
    CHECK(!usb_cdc_port_open(&dev));
    CHECK(!control(&dev, &f, H2D_CLASS_IF, 0x22, 1, 0, 0, NULL).stalled);
    usb_dev_bus_reset(&dev);
    CHECK(!usb_cdc_port_open(&dev));
}

TEST(usb_suspend_from_each_state) {
    for (int state = 0; state < 3; state++) {
        usb_dev_t dev;
        fake_udc_t f;
        to_state(&dev, &f, state);
        const usb_state_t before = dev.state;
        usb_dev_suspend(&dev);
        usb_dev_suspend(&dev); /* twice: still returns to the state before the first */
        CHECK_EQ(dev.state, USB_STATE_SUSPENDED);
        usb_dev_resume(&dev);
        CHECK_EQ(dev.state, before);
        /* A SETUP while suspended is bus activity: it resumes the device and is answered. */
        usb_dev_suspend(&dev);
        const xfer_t x = control(&dev, &f, D2H_DEV, 6, 0x0100, 0, 18, NULL);
        CHECK(!x.stalled);
        CHECK_EQ(dev.state, before);
        /* A bus reset while suspended goes to Default. */
        usb_dev_suspend(&dev);
        usb_dev_bus_reset(&dev);
        CHECK_EQ(dev.state, USB_STATE_DEFAULT);
    }
}

TEST(usb_endpoint_halt) {
    usb_dev_t dev;
    fake_udc_t f;
    to_state(&dev, &f, 2);
    CHECK(!control(&dev, &f, H2D_EP, 3, 0, 0x81, 0, NULL).stalled);
    CHECK_EQ(f.halt_ep, 0x81);
    CHECK_EQ(f.halt_value, 1);
    xfer_t x = control(&dev, &f, D2H_EP, 0, 0, 0x81, 2, NULL);
    CHECK_EQ(x.len, 2);
    CHECK_EQ(x.data[0], 1);
    x = control(&dev, &f, D2H_EP, 0, 0, 0x01, 2, NULL);
    CHECK_EQ(x.data[0], 0); /* the other direction is independent */
    CHECK(!control(&dev, &f, H2D_EP, 1, 0, 0x81, 0, NULL).stalled);
    CHECK_EQ(f.halt_value, 0);
    x = control(&dev, &f, D2H_EP, 0, 0, 0x81, 2, NULL);
    CHECK_EQ(x.data[0], 0);
    /* SET_INTERFACE on the data interface clears its endpoints' halts. */
    CHECK(!control(&dev, &f, H2D_EP, 3, 0, 0x01, 0, NULL).stalled);
    CHECK(!control(&dev, &f, H2D_IF, 11, 0, 1, 0, NULL).stalled);
    x = control(&dev, &f, D2H_EP, 0, 0, 0x01, 2, NULL);
    CHECK_EQ(x.data[0], 0);
    /* SET_CONFIGURATION clears them too. */
    CHECK(!control(&dev, &f, H2D_EP, 3, 0, 0x82, 0, NULL).stalled);
    CHECK(!control(&dev, &f, H2D_DEV, 9, 1, 0, 0, NULL).stalled);
    x = control(&dev, &f, D2H_EP, 0, 0, 0x82, 2, NULL);
    CHECK_EQ(x.data[0], 0);
}

TEST(usb_host_ends_read_early) {
    usb_dev_t dev;
    fake_udc_t f;
    to_state(&dev, &f, 1);
    const uint8_t setup[8] = {D2H_DEV, 6, 0, 2, 0, 0, 0xFF, 0};
    const uint32_t sends = f.sends;
    usb_dev_setup(&dev, setup);
    CHECK_EQ(dev.ep0, USB_EP0_DATA_IN);
    usb_dev_ep0_out(&dev, NULL, 0); /* status OUT after the first packet */
    CHECK_EQ(dev.ep0, USB_EP0_IDLE);
    usb_dev_ep0_in_done(&dev); /* the packet already in the FIFO completes: nothing more */
    CHECK_EQ(f.sends, sends + 1u);
    CHECK_EQ(dev.stalls, 0);
}

TEST(usb_status_out_with_data_stalls) {
    usb_dev_t dev;
    fake_udc_t f;
    to_state(&dev, &f, 1);
    const uint8_t setup[8] = {D2H_DEV, 6, 0, 1, 0, 0, 18, 0};
    usb_dev_setup(&dev, setup);
    usb_dev_ep0_in_done(&dev);
    CHECK_EQ(dev.ep0, USB_EP0_STATUS_OUT);
    CHECK_EQ(f.receives, 1);
    const uint8_t junk[2] = {1, 2};
    usb_dev_ep0_out(&dev, junk, 2);
    CHECK_EQ(dev.ep0, USB_EP0_STALLED);
}

/* Walk the configuration descriptor: lengths chain to wTotalLength, the counts agree. */
TEST(usb_descriptor_chain_consistent) {
    const uint8_t *d = k_usb_config_desc;
    const uint32_t total = (uint32_t)(d[2] | (d[3] << 8));
    CHECK_EQ(total, sizeof k_usb_config_desc);
    uint32_t at = 0;
    uint32_t interfaces = 0;
    int endpoints_left = 0;
    int iad = 0;
    while (at < total) {
        const uint8_t len = d[at];
        CHECK(len >= 2u);
        CHECK(at + len <= total);
        switch (d[at + 1]) {
        case 0x04:
            CHECK_EQ(endpoints_left, 0);
            CHECK_EQ(d[at + 2], interfaces);
            endpoints_left = d[at + 4];
            interfaces++;
            break;
        case 0x05:
            CHECK_EQ(len, 7);
            endpoints_left--;
            CHECK(endpoints_left >= 0);
            break;
        case 0x0B:
            CHECK_EQ(interfaces, 0); /* the IAD precedes the interfaces it groups */
            iad++;
            break;
        default:
            break;
        }
        at += len;
    }
    CHECK_EQ(at, total);
    CHECK_EQ(endpoints_left, 0);
    CHECK_EQ(interfaces, d[4]);
    CHECK_EQ(iad, 1);
}

TEST(usb_serial_from_uid) {
    uint8_t s[USB_SERIAL_DESC_LEN];
    usb_desc_serial(s, k_uid);
    CHECK_EQ(s[0], USB_SERIAL_DESC_LEN);
    CHECK_EQ(s[1], 3);
    static const char want[] = "123456789ABCDEF001234567";
    for (uint32_t i = 0; i < 24u; i++) {
        CHECK_EQ(s[2u + 2u * i], want[i]);
        CHECK_EQ(s[3u + 2u * i], 0);
    }
}

TEST(usb_enumeration_sequence) {
    /* The order Linux uses: 64-byte device read at address 0, reset, SET_ADDRESS, full reads,
     * SET_CONFIGURATION, then cdc_acm's line coding and DTR on open. */
    usb_dev_t dev;
    fake_udc_t f;
    enumerate(&dev, &f, &g_fake_driver_early, 23);
    CHECK_EQ(dev.state, USB_STATE_CONFIGURED);
    CHECK_EQ(dev.address, 23);
    CHECK_EQ(f.hw_address, 23);
    CHECK_EQ(dev.stalls, 0);
    static const uint8_t line[7] = {0x00, 0x10, 0x0E, 0x00, 0, 0, 8};
    CHECK(!control(&dev, &f, H2D_CLASS_IF, 0x20, 0, 0, 7, line).stalled);
    CHECK(!control(&dev, &f, H2D_CLASS_IF, 0x22, 3, 0, 0, NULL).stalled);
    CHECK(usb_cdc_port_open(&dev));
}

/* Random events (SETUPs with random fields, data, completions, resets, suspends) under the
 * sanitizers: the core never sends a packet over 64 bytes nor more than wLength in one data
 * stage, is never Configured without an address, and its EP0 stage stays consistent. */
/* --- CDC data path (usb_cdc_io) --------------------------------------------------------- */

/* Drain the transmit ring the way the interrupt does; returns the packet lengths. */
static uint32_t drain(usb_cdc_io_t *io, uint8_t *out, uint32_t *lens, uint32_t max_packets) {
    uint32_t packets = 0u;
    uint32_t at = 0u;
    uint8_t packet[USB_DATA_SIZE];
    uint32_t n = 0u;
    while (packets < max_packets && usb_cdc_io_next_packet(io, packet, &n)) {
        memcpy(out + at, packet, n);
        at += n;
        lens[packets++] = n;
    }
    return packets;
}

TEST(usb_cdc_tx_packets_and_zlp) {
    static usb_cdc_io_t io;
    usb_cdc_io_init(&io);
    uint8_t frame[200];
    for (uint32_t i = 0; i < sizeof frame; i++) {
        frame[i] = (uint8_t)(i * 7u + 1u);
    }
    uint8_t out[512];
    uint32_t lens[16];
    /* 200 bytes: 64 + 64 + 64 + 8, no ZLP (the last packet is short). */
    CHECK_EQ(usb_cdc_io_write(&io, frame, 200), 200);
    CHECK_EQ(drain(&io, out, lens, 16), 4);
    CHECK_EQ(lens[0], 64);
    CHECK_EQ(lens[3], 8);
    CHECK(memcmp(out, frame, 200) == 0);
    /* 128 bytes: two full packets, then the zero-length packet, then nothing. */
    CHECK_EQ(usb_cdc_io_write(&io, frame, 128), 128);
    CHECK_EQ(drain(&io, out, lens, 16), 3);
    CHECK_EQ(lens[1], 64);
    CHECK_EQ(lens[2], 0);
    CHECK(memcmp(out, frame, 128) == 0);
    /* More data arriving before the ZLP went out continues the transfer instead. */
    CHECK_EQ(usb_cdc_io_write(&io, frame, 64), 64);
    uint8_t packet[USB_DATA_SIZE];
    uint32_t n = 0u;
    CHECK(usb_cdc_io_next_packet(&io, packet, &n));
    CHECK_EQ(n, 64);
    CHECK_EQ(usb_cdc_io_write(&io, frame, 5), 5);
    CHECK_EQ(drain(&io, out, lens, 16), 1);
    CHECK_EQ(lens[0], 5);
}

TEST(usb_cdc_tx_all_or_nothing_and_wrap) {
    static usb_cdc_io_t io;
    usb_cdc_io_init(&io);
    static uint8_t big[USB_CDC_TX_SIZE + 1u];
    CHECK_EQ(usb_cdc_io_write(&io, big, USB_CDC_TX_SIZE + 1u), 0); /* never part of a frame */
    CHECK_EQ(usb_cdc_io_tx_queued(&io), 0);
    /* Many odd-sized frames through the ring: every byte comes out once, in order. */
    uint8_t frame[77];
    uint8_t out[USB_DATA_SIZE];
    uint32_t next_in = 0u;
    uint32_t next_out = 0u;
    for (uint32_t round = 0; round < 500u; round++) {
        for (uint32_t i = 0; i < sizeof frame; i++) {
            frame[i] = (uint8_t)(next_in + i);
        }
        if (usb_cdc_io_write(&io, frame, sizeof frame) == sizeof frame) {
            next_in += sizeof frame;
        }
        uint32_t n = 0u;
        for (int k = 0; k < 1 + (int)(round % 2u); k++) {
            if (usb_cdc_io_next_packet(&io, out, &n)) {
                for (uint32_t i = 0; i < n; i++) {
                    CHECK_EQ(out[i], (uint8_t)(next_out + i));
                }
                next_out += n;
            }
        }
    }
    CHECK(next_in > 4u * USB_CDC_TX_SIZE); /* the indexes wrapped the ring several times */
    CHECK(next_out + usb_cdc_io_tx_queued(&io) == next_in);
    /* A full ring refuses a frame, and dropping empties it. */
    while (usb_cdc_io_write(&io, frame, sizeof frame) != 0u) {
    }
    CHECK(usb_cdc_io_tx_queued(&io) > USB_CDC_TX_SIZE - sizeof frame);
    usb_cdc_io_drop_tx(&io);
    CHECK_EQ(usb_cdc_io_tx_queued(&io), 0);
    uint32_t n = 0u;
    CHECK(!usb_cdc_io_next_packet(&io, out, &n));
}

TEST(usb_cdc_rx_flow_control) {
    static usb_cdc_io_t io;
    usb_cdc_io_init(&io);
    uint8_t packet[USB_DATA_SIZE];
    for (uint32_t i = 0; i < sizeof packet; i++) {
        packet[i] = (uint8_t)i;
    }
    /* Room for exactly RX_SIZE / 64 packets, then the endpoint must NAK. */
    uint32_t pushed = 0u;
    while (usb_cdc_io_rx_room(&io)) {
        usb_cdc_io_rx_push(&io, packet, sizeof packet);
        pushed++;
    }
    CHECK_EQ(pushed, USB_CDC_RX_SIZE / USB_DATA_SIZE);
    uint8_t buf[USB_CDC_RX_SIZE];
    CHECK_EQ(usb_cdc_io_read(&io, buf, 10), 10);
    CHECK(!usb_cdc_io_rx_room(&io)); /* 10 bytes free is not a packet */
    CHECK_EQ(usb_cdc_io_read(&io, buf, 54), 54);
    CHECK(usb_cdc_io_rx_room(&io));
    usb_cdc_io_rx_push(&io, packet, 3); /* short packets are stored as they are */
    CHECK_EQ(usb_cdc_io_read(&io, buf, sizeof buf), USB_CDC_RX_SIZE - 64u + 3u);
    CHECK_EQ(buf[0], 0);
    CHECK_EQ(buf[63], 63);
    CHECK_EQ(buf[USB_CDC_RX_SIZE - 64u + 2u], 2);
    CHECK_EQ(usb_cdc_io_read(&io, buf, sizeof buf), 0);
}

#define NCASES (uint32_t)(sizeof k_cases / sizeof k_cases[0])

TEST(usb_random_events_keep_invariants) {
    usb_dev_t dev;
    fake_udc_t f;
    fresh(&dev, &f);
    uint32_t x = 0x12345678u; /* xorshift32: the same sequence on every run */
    uint32_t stage_bytes = 0u;
    uint32_t w_length = 0u;
    for (uint32_t step = 0; step < 200000u; step++) {
        x ^= x << 13;
        x ^= x >> 17;
        x ^= x << 5;
        const uint32_t what = x % 16u;
        if (what < 6u) {
            /* A request of the table, SET_ADDRESS or SET_CONFIGURATION (so that every state is
             * reached), one byte of it sometimes replaced by a random one. */
            const uint32_t pick = (x >> 4) % (NCASES + 2u);
            uint8_t setup[8];
            if (pick < NCASES) {
                const req_case_t *c = &k_cases[pick];
                const uint8_t b[8] = {c->bm, c->request, (uint8_t)c->value,
                                      (uint8_t)(c->value >> 8), (uint8_t)c->index,
                                      (uint8_t)(c->index >> 8), (uint8_t)c->length,
                                      (uint8_t)(c->length >> 8)};
                memcpy(setup, b, 8);
            } else {
                const uint8_t set_address[8] = {H2D_DEV, 5, (uint8_t)(1u + (x >> 9) % 127u),
                                                0, 0, 0, 0, 0};
                const uint8_t set_config[8] = {H2D_DEV, 9, 1, 0, 0, 0, 0, 0};
                memcpy(setup, pick == NCASES ? set_address : set_config, 8);
            }
            if ((x >> 16) % 4u == 0u) {
                setup[(x >> 18) % 8u] = (uint8_t)(x >> 24);
            }
            f.queued = 0u;
            usb_dev_setup(&dev, setup);
            stage_bytes = 0u;
            w_length = (uint32_t)(setup[6] | (setup[7] << 8));
        } else if (what < 11u) {
            usb_dev_ep0_in_done(&dev);
        } else if (what < 14u) {
            const uint8_t data[64] = {0, 0xC2, 1, 0, 0, 0, 8};
            usb_dev_ep0_out(&dev, data, (x >> 8) % 65u);
        } else if (what == 14u) {
            usb_dev_suspend(&dev);
        } else if ((x >> 8) % 8u == 0u) {
            usb_dev_bus_reset(&dev);
        } else {
            usb_dev_resume(&dev);
        }
        for (uint32_t i = 0; i < f.queued; i++) {
            CHECK(f.packet_len[i] <= USB_EP0_SIZE);
            stage_bytes += f.packet_len[i];
        }
        f.queued = 0u;
        if ((dev.setup[0] & 0x80u) != 0u) {
            CHECK(stage_bytes <= w_length);
        }
        CHECK(dev.state != USB_STATE_CONFIGURED || dev.address != 0u);
        CHECK(dev.ep0 <= USB_EP0_STALLED);
        CHECK(dev.ep0 != USB_EP0_DATA_IN || dev.in_left <= w_length);
    }
}

/* Dropping DTR closes the port once: the driver then drops the transmit ring (up to 2 KB of
 * frames that would otherwise reach the next program to open the port). */
TEST(usb_dtr_drop_counts_a_close) {
    usb_dev_t dev;
    fake_udc_t f;
    to_state(&dev, &f, 2);
    CHECK(!control(&dev, &f, H2D_CLASS_IF, 0x22, 0, 0, 0, NULL).stalled);
    CHECK_EQ(dev.port_closes, 0u); /* was not open: nothing to drop */
    CHECK(!control(&dev, &f, H2D_CLASS_IF, 0x22, 3, 0, 0, NULL).stalled);
    CHECK_EQ(dev.port_closes, 0u);
    CHECK(!control(&dev, &f, H2D_CLASS_IF, 0x22, 2, 0, 0, NULL).stalled); /* DTR off */
    CHECK_EQ(dev.port_closes, 1u);
    CHECK(!control(&dev, &f, H2D_CLASS_IF, 0x22, 0, 0, 0, NULL).stalled);
    CHECK_EQ(dev.port_closes, 1u);
}

static const test_case_t k_tests[] = {
    {"usb_dtr_drop_counts_a_close", usb_dtr_drop_counts_a_close},
    {"usb_request_table", usb_request_table},
    {"usb_stall_ends_at_next_setup", usb_stall_ends_at_next_setup},
    {"usb_device_descriptor_bytes", usb_device_descriptor_bytes},
    {"usb_multi_packet_in_and_truncation", usb_multi_packet_in_and_truncation},
    {"usb_zlp_rule", usb_zlp_rule},
    {"usb_short_answer_has_no_zlp", usb_short_answer_has_no_zlp},
    {"usb_address_applied_after_status_stage", usb_address_applied_after_status_stage},
    {"usb_address_early_for_otg_cores", usb_address_early_for_otg_cores},
    {"usb_address_lost_when_status_never_completes",
     usb_address_lost_when_status_never_completes},
    {"usb_configuration_set_and_cleared", usb_configuration_set_and_cleared},
    {"usb_line_coding_round_trip", usb_line_coding_round_trip},
    {"usb_line_coding_overlong_data_stage_stalls", usb_line_coding_overlong_data_stage_stalls},
    {"usb_dtr_opens_the_port", usb_dtr_opens_the_port},
    {"usb_suspend_from_each_state", usb_suspend_from_each_state},
    {"usb_endpoint_halt", usb_endpoint_halt},
    {"usb_host_ends_read_early", usb_host_ends_read_early},
    {"usb_status_out_with_data_stalls", usb_status_out_with_data_stalls},
    {"usb_descriptor_chain_consistent", usb_descriptor_chain_consistent},
    {"usb_serial_from_uid", usb_serial_from_uid},
    {"usb_enumeration_sequence", usb_enumeration_sequence},
    {"usb_random_events_keep_invariants", usb_random_events_keep_invariants},
    {"usb_cdc_tx_packets_and_zlp", usb_cdc_tx_packets_and_zlp},
    {"usb_cdc_tx_all_or_nothing_and_wrap", usb_cdc_tx_all_or_nothing_and_wrap},
    {"usb_cdc_rx_flow_control", usb_cdc_rx_flow_control},
    {NULL, NULL},
};

static void dump(const char *name, const uint8_t *d, uint32_t len) {
    printf("%s ", name);
    for (uint32_t i = 0; i < len; i++) {
        printf("%02x", d[i]);
    }
    printf("\n");
}

/* The descriptors exactly as the device answers GET_DESCRIPTOR (wLength 0xFFFF). */
static int dump_descriptors(void) {
    usb_dev_t dev;
    fake_udc_t f;
    to_state(&dev, &f, 1);
    static const struct {
        const char *name;
        uint16_t value, index;
    } which[] = {
        {"device", 0x0100, 0},          {"configuration", 0x0200, 0},
        {"string0", 0x0300, 0},         {"string1", 0x0301, 0x0409},
        {"string2", 0x0302, 0x0409},    {"string3", 0x0303, 0x0409},
    };
    for (size_t i = 0; i < sizeof which / sizeof which[0]; i++) {
        const xfer_t x = control(&dev, &f, D2H_DEV, 6, which[i].value, which[i].index, 0xFFFF,
                                 NULL);
        if (x.stalled) {
            printf("%s stalled\n", which[i].name);
            return 1;
        }
        dump(which[i].name, x.data, x.len);
    }
    return 0;
}

int main(int argc, char **argv) {
    const char *only = argc > 1 ? argv[1] : NULL;
    if (only != NULL && strcmp(only, "--descriptors") == 0) {
        return dump_descriptors();
    }
    static const test_case_t *const tables[] = {k_tests};
    return check_main(tables, 1, only);
}
