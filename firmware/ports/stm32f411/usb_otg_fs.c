/* USB CDC-ACM host link on the STM32F411's OTG_FS controller (PA11 DM, PA12 DP, AF10), device
 * mode, full speed, the controller's internal PHY. The chapter-9 and CDC logic lives in the
 * portable core (firmware/usb); this file is the controller driver underneath it and the data
 * path above it. Everything USB happens in OTG_FS_IRQHandler; the superloop only fills and
 * empties two rings and pends the interrupt so the handler moves them on.
 *
 * Register use follows RM0383 chapter 22 (OTG_FS), its programming model sections: core
 * initialisation, device initialisation, endpoint initialisation on USB reset and on
 * enumeration completion, the receive FIFO read (GRXSTSP packet status), and the FIFO RAM
 * allocation rules. */
#include <string.h>

#include "clock.h"
#include "gpio.h"
#include "host_link.h"
#include "irq.h"
#include "regs.h"
#include "timebase.h"
#include "usb_cdc_io.h"
#include "usb_dev.h"

/* Data FIFO RAM is 1.25 KB = 320 words (RM0383, OTG_FS FIFO RAM allocation), in words:
 *   RX (shared by all OUT endpoints): the manual's device-mode minimum is
 *     (4 x control endpoints + 6) + (largest packet / 4 + 1) + 2 x OUT endpoints + 1 = 32 here;
 *     128 holds several packets so the bus is not NAKed while the handler drains one;
 *   EP0 TX: one 64-byte control packet (16 words is also the minimum depth);
 *   EP1 TX (bulk IN): two 64-byte packets;
 *   EP2 TX (interrupt IN): one 16-byte notification, at the minimum depth of 16 words. */
#define FIFO_RX_WORDS 128u
#define FIFO_EP0_WORDS 16u
#define FIFO_EP1_WORDS 128u
#define FIFO_EP2_WORDS 16u
_Static_assert(FIFO_RX_WORDS + FIFO_EP0_WORDS + FIFO_EP1_WORDS + FIFO_EP2_WORDS <= 320u,
               "OTG_FS data FIFO RAM is 320 words");

#define EP_DATA 1u   /* bulk OUT 0x01 and bulk IN 0x81 */
#define EP_NOTIFY 2u /* interrupt IN 0x82 */
#define EPTYP_BULK 2u
#define EPTYP_INTERRUPT 3u

/* Bounds on the controller's own flags (reset and flush finish within a few PHY clocks). */
#define FLAG_SPINS 100000u
#define MODE_SWITCH_US 25000u /* forcing device mode takes effect after 25 ms (GUSBCFG FDMOD) */
#define PA_DM 11u
#define PA_DP 12u
#define AF_OTG_FS 10u

static usb_dev_t g_dev;
static uint8_t g_ep0_out[USB_EP0_SIZE];
static uint32_t g_ep0_out_len;
static uint8_t g_setup[8];
static usb_cdc_io_t g_io;
static volatile uint8_t g_tx_busy;  /* a bulk IN packet is in the FIFO */
static volatile uint8_t g_rx_armed; /* EP1 OUT accepts a packet */
static uint8_t g_running;           /* the controller was brought up */
static uint32_t g_closes_seen;      /* g_dev.port_closes already acted on (interrupt only) */

static int wait_reg(volatile uint32_t *reg, uint32_t mask, uint32_t value) {
    for (uint32_t i = 0; i < FLAG_SPINS; i++) {
        if ((*reg & mask) == value) {
            return 1;
        }
    }
    return 0;
}

static void pend_irq(void) {
    NVIC_ISPR(OTG_FS_IRQN / 32u) = 1u << (OTG_FS_IRQN % 32u);
}

/* Copy a packet into TX FIFO `ep`, whole words (the last one padded). */
static void fifo_write(uint32_t ep, const uint8_t *data, uint32_t len) {
    for (uint32_t i = 0; i < len; i += 4u) {
        uint32_t w = 0u;
        for (uint32_t b = 0; b < 4u && i + b < len; b++) {
            w |= (uint32_t)data[i + b] << (8u * b);
        }
        OTG_FIFO(ep) = w;
    }
}

/* Pop `len` bytes from the RX FIFO into dst (NULL: discard), whole words. */
static void fifo_read(uint8_t *dst, uint32_t len) {
    for (uint32_t i = 0; i < len; i += 4u) {
        const uint32_t w = OTG_FIFO(0u);
        for (uint32_t b = 0; b < 4u && i + b < len; b++) {
            if (dst != 0) {
                dst[i + b] = (uint8_t)(w >> (8u * b));
            }
        }
    }
}

static void flush_tx_fifo(uint32_t num) { /* num 0x10: all */
    OTG_GRSTCTL = OTG_GRSTCTL_TXFFLSH | (num << OTG_GRSTCTL_TXFNUM_SHIFT);
    (void)wait_reg(&OTG_GRSTCTL, OTG_GRSTCTL_TXFFLSH, 0u);
}

/* --- usb_driver_t for the portable core ------------------------------------------------- */

static void drv_ep0_send(void *ctx, const uint8_t *data, uint32_t len) {
    (void)ctx;
    /* Transfer size, then enable, then the data (RM0383 OTG_FS programming model, IN data
     * transfers). */
    OTG_DIEPTSIZ(0u) = (1u << OTG_TSIZ_PKTCNT_SHIFT) | len;
    OTG_DIEPCTL(0u) |= OTG_EPCTL_EPENA | OTG_EPCTL_CNAK;
    fifo_write(0u, data, len);
}

static void drv_ep0_receive(void *ctx) {
    (void)ctx;
    OTG_DOEPTSIZ(0u) = (3u << OTG_DOEPTSIZ0_STUPCNT_SHIFT) | (1u << OTG_TSIZ_PKTCNT_SHIFT) |
                       USB_EP0_SIZE;
    OTG_DOEPCTL(0u) |= OTG_EPCTL_EPENA | OTG_EPCTL_CNAK;
}

static void drv_ep0_stall(void *ctx) {
    (void)ctx;
    /* The controller clears EP0's STALL itself when the next SETUP arrives. */
    OTG_DIEPCTL(0u) |= OTG_EPCTL_STALL;
    OTG_DOEPCTL(0u) |= OTG_EPCTL_STALL;
}

static void drv_set_address(void *ctx, uint8_t address) {
    (void)ctx;
    OTG_DCFG = (OTG_DCFG & ~OTG_DCFG_DAD_MASK) | ((uint32_t)address << OTG_DCFG_DAD_SHIFT);
}

static void arm_data_out(void) {
    if (usb_cdc_io_rx_room(&g_io)) {
        OTG_DOEPTSIZ(EP_DATA) = (1u << OTG_TSIZ_PKTCNT_SHIFT) | USB_DATA_SIZE;
        OTG_DOEPCTL(EP_DATA) |= OTG_EPCTL_EPENA | OTG_EPCTL_CNAK;
        g_rx_armed = 1u;
    } else {
        g_rx_armed = 0u; /* the endpoint NAKs until the superloop makes room */
    }
}

/* Stop an IN endpoint that may hold a packet: disable it (bounded) and flush its FIFO. */
static void in_endpoint_off(uint32_t ep) {
    if ((OTG_DIEPCTL(ep) & OTG_EPCTL_EPENA) != 0u) {
        OTG_DIEPCTL(ep) |= OTG_EPCTL_SNAK | OTG_EPCTL_EPDIS;
        (void)wait_reg(&OTG_DIEPINT(ep), OTG_EPINT_EPDISD, OTG_EPINT_EPDISD);
        OTG_DIEPINT(ep) = OTG_EPINT_EPDISD;
    }
    OTG_DIEPCTL(ep) &= ~OTG_EPCTL_USBAEP;
    flush_tx_fifo(ep);
}

static void drv_configure(void *ctx, uint8_t on) {
    (void)ctx;
    if (on == 0u) {
        in_endpoint_off(EP_DATA);
        in_endpoint_off(EP_NOTIFY);
        OTG_DOEPCTL(EP_DATA) = (OTG_DOEPCTL(EP_DATA) & ~OTG_EPCTL_USBAEP) | OTG_EPCTL_SNAK;
        OTG_DAINTMSK = 1u | (1u << OTG_DAINTMSK_OEPM_SHIFT); /* EP0 IN and OUT only */
        g_tx_busy = 0u;
        usb_cdc_io_drop_tx(&g_io); /* frames queued for a host that went away */
        g_rx_armed = 0u;
        return;
    }
    OTG_DIEPCTL(EP_DATA) = OTG_EPCTL_USBAEP | (EPTYP_BULK << OTG_EPCTL_EPTYP_SHIFT) |
                           (EP_DATA << OTG_EPCTL_TXFNUM_SHIFT) | OTG_EPCTL_SD0PID |
                           OTG_EPCTL_SNAK | USB_DATA_SIZE;
    OTG_DIEPCTL(EP_NOTIFY) = OTG_EPCTL_USBAEP | (EPTYP_INTERRUPT << OTG_EPCTL_EPTYP_SHIFT) |
                             (EP_NOTIFY << OTG_EPCTL_TXFNUM_SHIFT) | OTG_EPCTL_SD0PID |
                             OTG_EPCTL_SNAK | USB_NOTIFY_SIZE;
    OTG_DOEPCTL(EP_DATA) = OTG_EPCTL_USBAEP | (EPTYP_BULK << OTG_EPCTL_EPTYP_SHIFT) |
                           OTG_EPCTL_SD0PID | USB_DATA_SIZE;
    OTG_DAINTMSK = 1u | (1u << EP_DATA) | (1u << EP_NOTIFY) | (1u << OTG_DAINTMSK_OEPM_SHIFT) |
                   (1u << (OTG_DAINTMSK_OEPM_SHIFT + EP_DATA));
    arm_data_out();
}

static void drv_ep_halt(void *ctx, uint8_t ep_address, uint8_t halt) {
    (void)ctx;
    const uint32_t ep = ep_address & 0x0Fu;
    volatile uint32_t *ctl = (ep_address & 0x80u) != 0u ? &OTG_DIEPCTL(ep) : &OTG_DOEPCTL(ep);
    if (halt != 0u) {
        *ctl |= OTG_EPCTL_STALL;
    } else {
        /* Clearing the halt restarts the data toggle at DATA0 (USB 2.0 §9.4.5). */
        *ctl = (*ctl & ~OTG_EPCTL_STALL) | OTG_EPCTL_SD0PID;
        if ((ep_address & 0x80u) == 0u && g_rx_armed == 0u) {
            arm_data_out();
        }
    }
}

static const usb_driver_t k_driver = {
    drv_ep0_send, drv_ep0_receive, drv_ep0_stall, drv_set_address, drv_configure, drv_ep_halt,
    1u, /* the Synopsys core needs DCFG.DAD before the status stage (RM0383 DCFG DAD) */
};

/* --- interrupt ---------------------------------------------------------------------------- */

/* Start the next bulk IN packet (or the ZLP that ends a transfer) when the endpoint is free. */
static void tx_kick(void) {
    if (g_tx_busy != 0u || g_dev.state != USB_STATE_CONFIGURED ||
        (g_dev.halted & 2u) != 0u) {
        return;
    }
    uint8_t packet[USB_DATA_SIZE];
    uint32_t n = 0u;
    if (!usb_cdc_io_next_packet(&g_io, packet, &n)) {
        return;
    }
    OTG_DIEPTSIZ(EP_DATA) = (1u << OTG_TSIZ_PKTCNT_SHIFT) | n;
    OTG_DIEPCTL(EP_DATA) |= OTG_EPCTL_EPENA | OTG_EPCTL_CNAK;
    fifo_write(EP_DATA, packet, n);
    g_tx_busy = 1u;
}

static void on_bus_reset(void) {
    for (uint32_t ep = 0; ep < 4u; ep++) {
        OTG_DOEPCTL(ep) |= OTG_EPCTL_SNAK;
    }
    flush_tx_fifo(0x10u);
    OTG_DAINTMSK = 1u | (1u << OTG_DAINTMSK_OEPM_SHIFT);
    OTG_DOEPMSK = OTG_DOEPINT_STUP | OTG_EPINT_XFRC;
    OTG_DIEPMSK = OTG_EPINT_XFRC;
    usb_dev_bus_reset(&g_dev); /* address 0, endpoints off */
    drv_ep0_receive(0);        /* ready for SETUP (STUPCNT 3) */
}

static void on_rx_fifo(void) {
    const uint32_t st = OTG_GRXSTSP;
    const uint32_t ep = st & OTG_GRXSTSP_EPNUM_MASK;
    const uint32_t len = (st & OTG_GRXSTSP_BCNT_MASK) >> OTG_GRXSTSP_BCNT_SHIFT;
    const uint32_t status = (st & OTG_GRXSTSP_PKTSTS_MASK) >> OTG_GRXSTSP_PKTSTS_SHIFT;
    if (status == OTG_PKTSTS_SETUP_DATA && len == 8u) {
        fifo_read(g_setup, 8u);
    } else if (status == OTG_PKTSTS_OUT_DATA && ep == 0u && len <= USB_EP0_SIZE) {
        fifo_read(g_ep0_out, len);
        g_ep0_out_len = len;
    } else if (status == OTG_PKTSTS_OUT_DATA && ep == EP_DATA && len <= USB_DATA_SIZE) {
        /* Room for a whole packet was checked when the endpoint was armed. */
        uint8_t packet[USB_DATA_SIZE];
        fifo_read(packet, len);
        usb_cdc_io_rx_push(&g_io, packet, len);
    } else {
        fifo_read(0, len); /* completion entries (len 0) and anything unexpected */
    }
}

static void on_out_endpoints(void) {
    const uint32_t daint = OTG_DAINT >> OTG_DAINT_OEPINT_SHIFT;
    if ((daint & 1u) != 0u) {
        const uint32_t irq = OTG_DOEPINT(0u);
        OTG_DOEPINT(0u) = irq;
        if ((irq & OTG_DOEPINT_STUP) != 0u) {
            usb_dev_setup(&g_dev, g_setup);
            if (g_dev.ep0 == USB_EP0_DATA_IN || g_dev.ep0 == USB_EP0_STATUS_IN) {
                drv_ep0_receive(0); /* keep accepting the next SETUP or an early status OUT */
            } else if (g_dev.ep0 == USB_EP0_STALLED) {
                /* Room for the next SETUPs without enabling the stalled endpoint. */
                OTG_DOEPTSIZ(0u) = (3u << OTG_DOEPTSIZ0_STUPCNT_SHIFT) |
                                   (1u << OTG_TSIZ_PKTCNT_SHIFT) | USB_EP0_SIZE;
            }
        } else if ((irq & OTG_EPINT_XFRC) != 0u) {
            const uint32_t len = g_ep0_out_len;
            g_ep0_out_len = 0u;
            usb_dev_ep0_out(&g_dev, g_ep0_out, len);
            if (g_dev.ep0 == USB_EP0_IDLE || g_dev.ep0 == USB_EP0_STATUS_IN) {
                drv_ep0_receive(0);
            }
        }
    }
    if ((daint & (1u << EP_DATA)) != 0u) {
        const uint32_t irq = OTG_DOEPINT(EP_DATA);
        OTG_DOEPINT(EP_DATA) = irq;
        if ((irq & OTG_EPINT_XFRC) != 0u) {
            arm_data_out();
        }
    }
}

static void on_in_endpoints(void) {
    const uint32_t daint = OTG_DAINT & OTG_DAINT_IEPINT_MASK;
    if ((daint & 1u) != 0u) {
        const uint32_t irq = OTG_DIEPINT(0u);
        OTG_DIEPINT(0u) = irq;
        if ((irq & OTG_EPINT_XFRC) != 0u) {
            usb_dev_ep0_in_done(&g_dev);
        }
    }
    if ((daint & (1u << EP_DATA)) != 0u) {
        const uint32_t irq = OTG_DIEPINT(EP_DATA);
        OTG_DIEPINT(EP_DATA) = irq;
        if ((irq & OTG_EPINT_XFRC) != 0u) {
            g_tx_busy = 0u;
        }
    }
    if ((daint & (1u << EP_NOTIFY)) != 0u) {
        OTG_DIEPINT(EP_NOTIFY) = OTG_DIEPINT(EP_NOTIFY); /* no notifications are sent */
    }
}

void OTG_FS_IRQHandler(void);
void OTG_FS_IRQHandler(void) {
    /* Each pass handles what is pending now; the interrupt re-enters for anything newer, so
     * the handler is bounded by the RX FIFO's depth (at most one entry per 2 words). */
    const uint32_t st = OTG_GINTSTS & OTG_GINTMSK;
    if ((st & OTG_GINT_USBRST) != 0u) {
        OTG_GINTSTS = OTG_GINT_USBRST;
        on_bus_reset();
    }
    if ((st & OTG_GINT_ENUMDNE) != 0u) {
        OTG_GINTSTS = OTG_GINT_ENUMDNE;
        OTG_DIEPCTL(0u) &= ~OTG_DIEPCTL0_MPSIZ_MASK; /* EP0 MPSIZ 0 = 64 bytes */
        OTG_DCTL |= OTG_DCTL_CGINAK;
    }
    for (uint32_t i = 0; i < FIFO_RX_WORDS / 2u && (OTG_GINTSTS & OTG_GINT_RXFLVL) != 0u; i++) {
        on_rx_fifo();
    }
    if ((st & OTG_GINT_OEPINT) != 0u) {
        on_out_endpoints();
        if (g_dev.port_closes != g_closes_seen) { /* DTR dropped: the reader went away */
            g_closes_seen = g_dev.port_closes;
            usb_cdc_io_drop_tx(&g_io);
        }
    }
    if ((st & OTG_GINT_IEPINT) != 0u) {
        on_in_endpoints();
    }
    if ((st & OTG_GINT_USBSUSP) != 0u) {
        OTG_GINTSTS = OTG_GINT_USBSUSP;
        usb_dev_suspend(&g_dev);
        OTG_PCGCCTL |= OTG_PCGCCTL_STPPCLK; /* the PHY idles until the host resumes the bus */
    }
    if ((st & OTG_GINT_WKUPINT) != 0u) {
        OTG_GINTSTS = OTG_GINT_WKUPINT;
        OTG_PCGCCTL &= ~OTG_PCGCCTL_STPPCLK;
        usb_dev_resume(&g_dev);
    }
    if (g_rx_armed == 0u && g_dev.state == USB_STATE_CONFIGURED && (g_dev.halted & 1u) == 0u) {
        arm_data_out();
    }
    tx_kick();
}

/* --- host link ---------------------------------------------------------------------------- */

void host_link_init(const clocks_t *clk, const uint8_t uid[12]) {
    usb_dev_init(&g_dev, &k_driver, 0, uid);
    usb_cdc_io_init(&g_io);
    /* Full speed needs 48 MHz +-0.25 % on PLL48CLK: only the crystal-driven PLL gives that
     * (clock.c); on either HSI fallback the board stays off the bus rather than misbehave on
     * it. */
    if (clk->usb_ok == 0u) {
        return;
    }
    gpio_af(GPIOA, PA_DM, AF_OTG_FS, 0, 0);
    gpio_af(GPIOA, PA_DP, AF_OTG_FS, 0, 0);
    GPIOA->OSPEEDR |= (GPIO_OSPEEDR_OSPEEDR0_VERYHIGH << (2u * PA_DM)) |
                      (GPIO_OSPEEDR_OSPEEDR0_VERYHIGH << (2u * PA_DP));
    RCC->AHB2ENR |= RCC_AHB2ENR_OTGFS;
    (void)RCC->AHB2ENR;

    /* Core initialisation (RM0383 OTG_FS programming model): idle AHB, soft reset, then
     * device mode. */
    if (!wait_reg(&OTG_GRSTCTL, OTG_GRSTCTL_AHBIDL, OTG_GRSTCTL_AHBIDL)) {
        return;
    }
    OTG_GRSTCTL = OTG_GRSTCTL_CSRST;
    if (!wait_reg(&OTG_GRSTCTL, OTG_GRSTCTL_CSRST, 0u) ||
        !wait_reg(&OTG_GRSTCTL, OTG_GRSTCTL_AHBIDL, OTG_GRSTCTL_AHBIDL)) {
        return;
    }
    OTG_DCTL = OTG_DCTL_SDIS; /* stay off the bus (no DP pull-up) until set up */
    /* TRDT 6: the turnaround for an AHB clock of 32 MHz and above (RM0383, GUSBCFG TRDT
     * table); HCLK is 96 MHz here. */
    OTG_GUSBCFG = OTG_GUSBCFG_FDMOD | OTG_GUSBCFG_PHYSEL | (6u << OTG_GUSBCFG_TRDT_SHIFT);
    const uint32_t t0 = timebase_now_us();
    while (timebase_now_us() - t0 < MODE_SWITCH_US) {
    }
    /* No VBUS sensing: the Black Pill does not wire VBUS to PA9 (USART1 TX in the other
     * build), and a bus-powered board only runs while VBUS is there (RM0383 GCCFG). */
    OTG_GCCFG = OTG_GCCFG_PWRDWN | OTG_GCCFG_NOVBUSSENS;
    OTG_PCGCCTL = 0u;

    /* Device initialisation (RM0383 OTG_FS programming model). */
    OTG_DCFG = OTG_DCFG_DSPD_FS;
    OTG_GRXFSIZ = FIFO_RX_WORDS;
    OTG_DIEPTXF0 = (FIFO_EP0_WORDS << OTG_DIEPTXF0_TX0FD_SHIFT) | FIFO_RX_WORDS;
    OTG_DIEPTXF(1u) = (FIFO_EP1_WORDS << OTG_DIEPTXF_INEPTXFD_SHIFT) | (FIFO_RX_WORDS + FIFO_EP0_WORDS);
    OTG_DIEPTXF(2u) = (FIFO_EP2_WORDS << OTG_DIEPTXF_INEPTXFD_SHIFT) |
                      (FIFO_RX_WORDS + FIFO_EP0_WORDS + FIFO_EP1_WORDS);
    flush_tx_fifo(0x10u);
    OTG_GRSTCTL = OTG_GRSTCTL_RXFFLSH;
    (void)wait_reg(&OTG_GRSTCTL, OTG_GRSTCTL_RXFFLSH, 0u);
    OTG_DIEPMSK = OTG_EPINT_XFRC;
    OTG_DOEPMSK = OTG_DOEPINT_STUP | OTG_EPINT_XFRC;
    OTG_GINTSTS = 0xFFFFFFFFu;
    OTG_GINTMSK = OTG_GINT_USBRST | OTG_GINT_ENUMDNE | OTG_GINT_RXFLVL | OTG_GINT_IEPINT |
                  OTG_GINT_OEPINT | OTG_GINT_USBSUSP | OTG_GINT_WKUPINT;
    OTG_GAHBCFG = OTG_GAHBCFG_GINTMSK;
    irq_enable(OTG_FS_IRQN, IRQ_PRIORITY_LINK);
    g_running = 1u;
    OTG_DCTL &= ~OTG_DCTL_SDIS; /* connect: the host sees the DP pull-up and resets us */
}

uint32_t host_link_write(const uint8_t *data, uint32_t len) {
    /* Nobody has the port open: drop the frame (counted by the core) rather than queue
     * stale frames for whoever opens it later. */
    if (g_running == 0u || !usb_cdc_port_open(&g_dev)) {
        return 0u;
    }
    const uint32_t n = usb_cdc_io_write(&g_io, data, len);
    if (n != 0u) {
        pend_irq();
    }
    return n;
}

uint32_t host_link_read(uint8_t *buf, uint32_t cap) {
    const uint32_t n = usb_cdc_io_read(&g_io, buf, cap);
    if (n > 0u && g_rx_armed == 0u && g_running != 0u) {
        pend_irq(); /* room again: let the handler re-arm EP1 OUT */
    }
    return n;
}

void host_link_service(void) {
    if (g_running != 0u && g_tx_busy == 0u && usb_cdc_io_tx_queued(&g_io) != 0u) {
        pend_irq();
    }
}

void host_link_flush(uint32_t timeout_us) {
    const uint32_t t0 = timebase_now_us();
    while (g_running != 0u && (usb_cdc_io_tx_queued(&g_io) != 0u || g_tx_busy != 0u) &&
           usb_cdc_port_open(&g_dev) && timebase_now_us() - t0 < timeout_us) {
        host_link_service();
    }
}

int host_link_suspended(void) {
    return g_dev.state == USB_STATE_SUSPENDED;
}
