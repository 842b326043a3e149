/* Runs the port's real i2c.c and gpio.c natively against a register-level model of the
 * STM32F411's I2C master (RM0383 chapter 18), its GPIO pads and a VEML3328 on each bus
 * (tests/firmware/test_i2c_model.py).
 *
 * The peripherals' bus addresses are mapped with no access rights, so every register access
 * of the driver faults: the SIGSEGV handler brings the model up to the present, writes the
 * values a read would return, opens the page and single-steps the one instruction (x86 trap
 * flag); the SIGTRAP handler then applies what the access did (a write's new value, a read's
 * side effect: SR1-then-SR2 clears ADDR, SR1-then-DR clears SB and BTF, DR reads pop RXNE)
 * and closes the page again. Time is simulated: each register access, clock read and link
 * service costs a few hundred ns, a byte on the bus 22.5 us (400 kHz).
 *
 * Modelled: START (waits while BUSY), address and data bytes with the slave's ACK/NACK, the
 * receiver's ACK/POS rule (POS = 1: a byte is acknowledged as ACK read at the previous
 * acknowledge pulse), BTF stretching, STOP after the current byte, STOP that cannot happen
 * because the slave holds SDA, BUSY set while a line is low and cleared by a STOP, SWRST,
 * the rc_w0 error flags; the pads' open-drain outputs and input levels, so nine SCL pulses
 * by GPIO walk a stuck slave to its acknowledge slot.
 *
 * Faults (argv[1] picks a scenario, see main): address NACK, a spurious BERR mid-transfer
 * (ST errata ES0287: the transfer itself is unaffected), arbitration lost on the address, a slave
 * holding SDA low (a read cut by a reset) at init or later, a slave holding SCL low for good,
 * and an interrupt of 100 us right after ADDR is cleared unless interrupts are masked.
 * Prints "rc N" per transfer, "data ..." for reads, "fltr", "ospeed" lines as asked, every
 * rule broken as "violation: ...", and "elapsed_us N" per transfer. */
#define _GNU_SOURCE
#include <signal.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <ucontext.h>
#include <unistd.h>

#include "generated/board.h"
#include "gpio.h"
#include "i2c.h"
#include "regs.h"
#include "stac_hal.h"

#define WIN_BASE 0x40000000ul
#define WIN_SIZE 0x30000ul
#define BYTE_NS 22500u    /* 9 clocks at 400 kHz */
#define ACCESS_NS 50u     /* one register access */
#define CLOCK_NS 200u     /* one read of the us clock */
#define SERVICE_NS 500u   /* one host_link_service() */
#define IRQ_NS 100000u    /* an interrupt taken right after ADDR is cleared */
#define HANG_NS 2000000000ull
#define VEML_ADDR 0x10u

/* ---------------------------------------------------------------- the simulated world ---- */

static uint64_t g_now;      /* ns */
static int g_irq_depth;     /* irq_save nesting: > 0 means masked */
static unsigned g_violations;
static char g_log[8192];
static size_t g_log_len;

static void violation(const char *text) {
    const int n = snprintf(g_log + g_log_len, sizeof g_log - g_log_len, "violation: %s\n", text);
    if (n > 0 && g_log_len + (size_t)n < sizeof g_log) {
        g_log_len += (size_t)n;
    }
    g_violations++;
}

enum phase { P_IDLE, P_SB, P_ADDR_TX, P_ADDR, P_DATA, P_NACKED };

typedef struct {
    /* VEML3328: 16-bit registers, pointer, transaction position */
    uint16_t reg[16];
    uint8_t ptr;
    int wr_count;      /* bytes written in this transaction */
    int rd_count;      /* bytes sent in this transaction */
    int tx_hold;       /* acknowledged as transmitter: drives the next byte's bits on SDA */
    uint8_t tx_byte;
    int tx_bit;        /* 0..7 data bits, 8 = master's acknowledge slot */
    int scl_stuck;     /* holds SCL low for good */
    int absent;
    /* I2C peripheral */
    uint32_t cr1, cr2, oar1, oar2, ccr, trise, fltr, sr1;
    int busy, msl, tra;
    int phase;
    int shifting;       /* a byte on the wire until shift_done */
    uint64_t shift_done;
    uint8_t shift;      /* byte on the wire (tx) */
    int rx;             /* receiver */
    int dr_full;        /* rx: RXNE; tx: DR written, not yet moved to the shift register */
    uint8_t dr;
    int shift_full;     /* rx: a received byte waits in the shift register (BTF) */
    uint8_t shift_byte;
    int last_ack;       /* rx: the last byte was acknowledged */
    int ack_latched;    /* ACK at the previous acknowledge pulse (POS = 1) */
    int stop_req, start_req;
    uint64_t start_at;
    int sr1_read;       /* SR1 read since the last SR2/DR access */
    uint64_t other_master_until; /* after arbitration lost: the other master's STOP */
    /* pads */
    int scl_line, sda_line;
    /* faults */
    int berr_in;        /* spurious BERR during the next data byte, counted down per byte */
    int arlo_next;      /* arbitration lost on the next address byte */
    int irq_after_addr; /* an interrupt right after ADDR is cleared in receive mode */
} bus_t;

static bus_t g_bus[3];
static const uintptr_t k_i2c_base[3] = {0x40005400u, 0x40005800u, 0x40005C00u};
#define GPIOA_BASE ((uintptr_t)0x40020000u)
#define GPIOB_BASE ((uintptr_t)0x40020400u)
static uint32_t g_gpio[2][10]; /* MODER OTYPER OSPEEDR PUPDR IDR ODR BSRR LCKR AFRL AFRH */

static void veml_reset(bus_t *b) {
    memset(b->reg, 0, sizeof b->reg);
    b->reg[0x00] = 0x8001u; /* shut down */
    b->reg[0x04] = 0x1234u;
    b->reg[0x05] = 0x2345u;
    b->reg[0x06] = 0x3456u;
    b->reg[0x07] = 0x4567u;
    b->reg[0x08] = 0x0567u;
    b->reg[0x0C] = 0x0028u;
}

/* ------------------------------------------------------------------- the slave -------- */

static int slave_sda_low(const bus_t *b) {
    return b->tx_hold && b->tx_bit < 8 && ((b->tx_byte >> (7 - b->tx_bit)) & 1u) == 0u;
}

static uint8_t slave_next_byte(bus_t *b) {
    const uint16_t v = b->reg[(b->ptr + b->rd_count / 2) & 0x0Fu];
    const uint8_t byte = (b->rd_count % 2) == 0 ? (uint8_t)v : (uint8_t)(v >> 8);
    b->rd_count++;
    return byte;
}

static void slave_start(bus_t *b) {
    b->wr_count = 0;
    b->rd_count = 0;
    b->tx_hold = 0;
}

static int slave_address(bus_t *b, uint8_t byte) {
    return !b->absent && (byte >> 1) == VEML_ADDR;
}

static int slave_write(bus_t *b, uint8_t byte) {
    if (b->wr_count == 0) {
        b->ptr = byte & 0x0Fu;
    } else if (b->wr_count == 1) {
        b->reg[b->ptr] = (uint16_t)((b->reg[b->ptr] & 0xFF00u) | byte);
    } else if (b->wr_count == 2) {
        b->reg[b->ptr] = (uint16_t)((b->reg[b->ptr] & 0x00FFu) | (byte << 8));
    }
    b->wr_count++;
    return 1;
}

/* The master answered a byte the slave sent: on ACK the slave goes on driving the next one. */
static void slave_master_answered(bus_t *b, int ack) {
    if (ack) {
        b->tx_hold = 1;
        b->tx_byte = slave_next_byte(b);
        b->rd_count--; /* sent only if the master clocks it out */
        b->tx_bit = 0;
    } else {
        b->tx_hold = 0;
    }
}

static void slave_stop(bus_t *b) {
    b->tx_hold = 0;
    b->wr_count = 0;
    b->rd_count = 0;
}

/* -------------------------------------------------------------------- the pads -------- */

static uint32_t field2(uint32_t reg, unsigned pin) {
    return (reg >> (2u * pin)) & 3u;
}

/* Is this pad pulling its line low? An output drives its ODR level; an alternate-function
 * pad belongs to the I2C block, which releases the lines between transfers. */
static int pad_low(const board_pin_t *p) {
    const uint32_t *g = g_gpio[p->port == 'A' ? 0 : 1];
    return field2(g[0], p->pin) == GPIO_MODER_MODER0_OUTPUT && ((g[5] >> p->pin) & 1u) == 0u;
}

static int pad_is_gpio(const board_pin_t *p) {
    const uint32_t *g = g_gpio[p->port == 'A' ? 0 : 1];
    return field2(g[0], p->pin) == GPIO_MODER_MODER0_OUTPUT;
}

static void lines_update(void) {
    for (unsigned k = 0; k < 3u; k++) {
        bus_t *b = &g_bus[k];
        const int scl = !(pad_low(&k_board_pins[2u * k]) || b->scl_stuck);
        int sda = !(pad_low(&k_board_pins[2u * k + 1u]) || slave_sda_low(b));
        if (!pad_is_gpio(&k_board_pins[2u * k])) {
            /* the I2C block clocks the bus: modelled byte by byte above, not edge by edge */
            b->scl_line = scl;
            b->sda_line = sda;
            continue;
        }
        if (b->scl_line && !scl && b->tx_hold) {
            /* falling SCL: the slave shifts out its next bit, or releases SDA for the ACK */
            b->tx_bit++;
            sda = !(pad_low(&k_board_pins[2u * k + 1u]) || slave_sda_low(b));
        }
        if (!b->scl_line && scl && b->tx_hold && b->tx_bit >= 8) {
            /* rising SCL in the acknowledge slot: SDA high is a NACK, the slave lets go */
            if (sda) {
                b->tx_hold = 0;
                b->rd_count++;
            } else {
                slave_master_answered(b, 1);
            }
        }
        if (scl && b->scl_line && sda != b->sda_line) {
            /* SDA changing while SCL is high: START (falling) or STOP (rising) */
            slave_stop(b);
            if (sda && (b->cr1 & I2C_CR1_PE) != 0u) {
                b->busy = 0;
            }
        }
        b->scl_line = scl;
        b->sda_line = sda;
        if ((!scl || !sda) && (b->cr1 & I2C_CR1_PE) != 0u) {
            b->busy = 1;
        }
    }
}

/* ---------------------------------------------------------------- the I2C block -------- */

static void start_shift(bus_t *b) {
    b->shifting = 1;
    b->shift_done = g_now + BYTE_NS;
}

static void do_stop(bus_t *b) {
    b->stop_req = 0;
    b->msl = 0;
    b->phase = P_IDLE;
    b->shifting = 0;
    if (b->tx_hold) {
        violation("STOP after an acknowledged last byte: the slave is still sending");
    }
    if (slave_sda_low(b)) {
        /* SDA held by the slave: no STOP on the bus, BUSY stays, STOP stays requested */
        b->cr1 |= I2C_CR1_STOP;
        b->busy = 1;
        return;
    }
    b->cr1 &= ~I2C_CR1_STOP;
    slave_stop(b);
    b->busy = 0;
}

static void byte_done(bus_t *b) {
    b->shifting = 0;
    if (b->phase == P_ADDR_TX) {
        if (b->arlo_next) {
            b->arlo_next = 0;
            b->sr1 |= I2C_SR1_ARLO;
            b->msl = 0;
            b->phase = P_IDLE;
            b->other_master_until = g_now + 3u * BYTE_NS;
            return;
        }
        if (slave_address(b, b->shift)) {
            b->sr1 |= I2C_SR1_ADDR;
            b->tra = (b->shift & 1u) == 0u;
            b->rx = !b->tra;
            b->phase = P_ADDR;
            b->ack_latched = (b->cr1 & I2C_CR1_ACK) != 0u;
        } else {
            b->sr1 |= I2C_SR1_AF;
            b->phase = P_NACKED;
        }
    } else if (b->rx) {
        const int ack = (b->cr1 & I2C_CR1_POS) != 0u ? b->ack_latched
                                                      : (b->cr1 & I2C_CR1_ACK) != 0u;
        b->ack_latched = (b->cr1 & I2C_CR1_ACK) != 0u;
        const uint8_t byte = slave_next_byte(b);
        slave_master_answered(b, ack);
        b->last_ack = ack;
        if (!b->dr_full) {
            b->dr = byte;
            b->dr_full = 1;
            b->sr1 |= I2C_SR1_RXNE;
            if (ack && !b->stop_req) {
                start_shift(b);
            }
        } else {
            b->shift_byte = byte;
            b->shift_full = 1;
            b->sr1 |= I2C_SR1_BTF;
        }
    } else {
        if (!slave_write(b, b->shift)) {
            b->sr1 |= I2C_SR1_AF;
            b->phase = P_NACKED;
        } else if (b->dr_full) {
            b->shift = b->dr;
            b->dr_full = 0;
            b->sr1 |= I2C_SR1_TXE;
            start_shift(b);
        } else {
            b->sr1 |= I2C_SR1_BTF | I2C_SR1_TXE;
        }
    }
    if (b->berr_in > 0 && b->phase == P_DATA && --b->berr_in == 0) {
        b->sr1 |= I2C_SR1_BERR; /* spurious: nothing else changes */
    }
}

static void bus_step(bus_t *b) {
    if ((b->cr1 & I2C_CR1_PE) == 0u) {
        return;
    }
    if (b->other_master_until != 0u && g_now >= b->other_master_until) {
        b->other_master_until = 0u;
        b->busy = 0; /* the other master's STOP */
    }
    if (b->shifting && g_now >= b->shift_done) {
        byte_done(b);
    }
    if (b->stop_req && !b->shifting && b->phase != P_SB && b->phase != P_ADDR_TX) {
        if (b->phase == P_IDLE && !b->msl) {
            b->stop_req = 0; /* nothing to stop */
            b->cr1 &= ~I2C_CR1_STOP;
        } else {
            do_stop(b);
        }
    }
    if (b->start_req && g_now >= b->start_at && !b->shifting) {
        const int repeated = b->msl && b->phase != P_IDLE;
        if (repeated || (!b->busy && b->other_master_until == 0u && b->scl_line && b->sda_line)) {
            b->start_req = 0;
            b->cr1 &= ~I2C_CR1_START;
            b->sr1 = (b->sr1 & ~(I2C_SR1_BTF | I2C_SR1_TXE)) | I2C_SR1_SB;
            b->msl = 1;
            b->busy = 1;
            b->phase = P_SB;
            b->shift_full = 0;
            b->dr_full = 0;
            slave_start(b);
        }
    }
}

static void world_step(void) {
    lines_update();
    for (unsigned k = 0; k < 3u; k++) {
        bus_step(&g_bus[k]);
    }
    if (g_now > HANG_NS) {
        printf("%sviolation: the driver was still waiting after 2 s of bus time\n", g_log);
        fflush(stdout);
        _exit(1);
    }
}

static void advance(uint64_t ns) {
    /* in steps, so that byte completions land in order */
    while (ns > 0u) {
        const uint64_t d = ns > 1000u ? 1000u : ns;
        g_now += d;
        ns -= d;
        world_step();
    }
}

static void i2c_reset(bus_t *b) {
    b->cr1 = 0u;
    b->sr1 = 0u;
    b->busy = b->msl = b->tra = 0;
    b->phase = P_IDLE;
    b->shifting = b->dr_full = b->shift_full = 0;
    b->stop_req = b->start_req = b->sr1_read = 0;
}

static uint32_t sr1_visible(const bus_t *b) {
    return b->sr1;
}

static uint32_t i2c_read_value(const bus_t *b, unsigned off) {
    switch (off) {
    case 0x00: return b->cr1;
    case 0x04: return b->cr2;
    case 0x08: return b->oar1;
    case 0x0C: return b->oar2;
    case 0x10: return b->rx ? b->dr : 0u;
    case 0x14: return sr1_visible(b);
    case 0x18: return (uint32_t)(b->msl | (b->busy << 1) | (b->tra << 2));
    case 0x1C: return b->ccr;
    case 0x20: return b->trise;
    case 0x24: return b->fltr;
    default: return 0u;
    }
}

static void i2c_after_read(bus_t *b, unsigned off) {
    if (off == 0x14) {
        b->sr1_read = 1;
        return;
    }
    if (off == 0x18) {
        if (b->sr1_read && (b->sr1 & I2C_SR1_ADDR) != 0u) {
            b->sr1 &= ~I2C_SR1_ADDR;
            b->phase = P_DATA;
            if (b->tra) {
                b->sr1 |= I2C_SR1_TXE;
            } else {
                start_shift(b);
                if (b->irq_after_addr && g_irq_depth == 0) {
                    b->irq_after_addr = 0;
                    advance(IRQ_NS); /* an interrupt handler runs before the next instruction */
                }
            }
        }
        b->sr1_read = 0;
        return;
    }
    if (off == 0x10 && b->rx && b->dr_full) {
        if (b->shift_full) {
            b->dr = b->shift_byte;
            b->shift_full = 0;
            b->sr1 &= ~I2C_SR1_BTF;
            if (b->last_ack && !b->stop_req && b->phase == P_DATA) {
                start_shift(b);
            }
        } else {
            b->dr_full = 0;
            b->sr1 &= ~I2C_SR1_RXNE;
        }
        b->sr1_read = 0;
    }
}

static void i2c_after_write(bus_t *b, unsigned off, uint32_t old, uint32_t v) {
    char text[120];
    switch (off) {
    case 0x00: {
        if ((v & I2C_CR1_SWRST) != 0u) {
            i2c_reset(b);
            b->cr1 = v;
            return;
        }
        const int was_on = (old & I2C_CR1_PE) != 0u;
        b->cr1 = v;
        if (!(v & I2C_CR1_PE)) {
            const uint32_t keep = b->cr1;
            const int busy = b->busy;
            i2c_reset(b);
            b->cr1 = keep;
            b->busy = busy;
            return;
        }
        if (!was_on) {
            b->busy = !b->scl_line || !b->sda_line;
        }
        if ((v & I2C_CR1_START) != 0u && !(old & I2C_CR1_START)) {
            b->start_req = 1;
            b->start_at = g_now + 1000u;
        }
        if ((v & I2C_CR1_STOP) != 0u && !(old & I2C_CR1_STOP)) {
            b->stop_req = 1;
        }
        return;
    }
    case 0x04: b->cr2 = v; return;
    case 0x08: b->oar1 = v; return;
    case 0x0C: b->oar2 = v; return;
    case 0x14: {
        const uint32_t rc_w0 = 0xDF00u; /* BERR ARLO AF OVR PECERR TIMEOUT SMBALERT */
        b->sr1 &= (v | ~rc_w0);
        return;
    }
    case 0x18: return; /* read only */
    case 0x1C:
    case 0x20:
    case 0x24:
        if ((b->cr1 & I2C_CR1_PE) != 0u) {
            snprintf(text, sizeof text, "I2C register +0x%02X written while PE = 1 (RM0383: PE = 0 only)",
                     off);
            violation(text);
        }
        if (off == 0x1C) {
            b->ccr = v;
        } else if (off == 0x20) {
            b->trise = v;
        } else {
            b->fltr = v;
        }
        return;
    case 0x10:
        if (b->phase == P_SB && b->sr1_read && (b->sr1 & I2C_SR1_SB) != 0u) {
            b->sr1 &= ~I2C_SR1_SB;
            b->shift = (uint8_t)v;
            b->phase = P_ADDR_TX;
            b->rx = 0;
            start_shift(b);
        } else if (b->phase == P_DATA && b->tra) {
            b->sr1 &= ~I2C_SR1_BTF;
            if (!b->shifting) {
                b->shift = (uint8_t)v;
                start_shift(b);
            } else {
                b->dr = (uint8_t)v;
                b->dr_full = 1;
                b->sr1 &= ~I2C_SR1_TXE;
            }
        } else {
            violation("DR written outside an address or transmit phase");
        }
        b->sr1_read = 0;
        return;
    default: return;
    }
}

/* ---------------------------------------------------------------- the trap ------------ */

static uintptr_t g_addr;
static int g_write;
static uint32_t g_old;

static void sync_out(void) {
    for (unsigned k = 0; k < 3u; k++) {
        for (unsigned off = 0; off < 0x28u; off += 4u) {
            *(volatile uint32_t *)(k_i2c_base[k] + off) = i2c_read_value(&g_bus[k], off);
        }
    }
    /* IDR of the two ports from the line levels and ODR */
    for (unsigned p = 0; p < 2u; p++) {
        uint32_t idr = g_gpio[p][5] & 0xFFFFu;
        for (unsigned i = 0; i < 6u; i++) {
            const board_pin_t *pin = &k_board_pins[i];
            if ((pin->port == 'A') != (p == 0u)) {
                continue;
            }
            const int level = (i % 2u) == 0u ? g_bus[i / 2u].scl_line : g_bus[i / 2u].sda_line;
            idr = level ? idr | (1u << pin->pin) : idr & ~(1u << pin->pin);
        }
        g_gpio[p][4] = idr;
        g_gpio[p][6] = 0u;
        for (unsigned r = 0; r < 10u; r++) {
            *(volatile uint32_t *)((p == 0u ? GPIOA_BASE : GPIOB_BASE) + 4u * r) = g_gpio[p][r];
        }
    }
}

static void on_segv(int sig, siginfo_t *si, void *ctx) {
    ucontext_t *uc = ctx;
    const uintptr_t a = (uintptr_t)si->si_addr;
    if (a < WIN_BASE || a >= WIN_BASE + WIN_SIZE) {
        signal(sig, SIG_DFL);
        return; /* a real crash: fault again, unhandled */
    }
    mprotect((void *)WIN_BASE, WIN_SIZE, PROT_READ | PROT_WRITE);
    g_now += ACCESS_NS;
    world_step();
    sync_out();
    g_addr = a & ~(uintptr_t)3u;
    g_write = (uc->uc_mcontext.gregs[REG_ERR] & 2) != 0;
    g_old = *(volatile uint32_t *)g_addr;
    uc->uc_mcontext.gregs[REG_EFL] |= 0x100; /* trap after this one instruction */
}

static void on_trap(int sig, siginfo_t *si, void *ctx) {
    (void)sig;
    (void)si;
    ucontext_t *uc = ctx;
    uc->uc_mcontext.gregs[REG_EFL] &= ~0x100;
    const uint32_t v = *(volatile uint32_t *)g_addr;
    if (getenv("I2C_MODEL_TRACE") != NULL) {
        fprintf(stderr, "%llu %s %05lx %08x\n", (unsigned long long)g_now, g_write ? "W" : "R",
                (unsigned long)(g_addr & 0xFFFFFu), (unsigned)v);
    }
    for (unsigned k = 0; k < 3u; k++) {
        if (g_addr >= k_i2c_base[k] && g_addr < k_i2c_base[k] + 0x28u) {
            const unsigned off = (unsigned)(g_addr - k_i2c_base[k]);
            if (g_write) {
                i2c_after_write(&g_bus[k], off, g_old, v);
            } else {
                i2c_after_read(&g_bus[k], off);
            }
        }
    }
    for (unsigned p = 0; p < 2u; p++) {
        const uintptr_t base = p == 0u ? GPIOA_BASE : GPIOB_BASE;
        if (g_write && g_addr >= base && g_addr < base + 40u) {
            const unsigned r = (unsigned)(g_addr - base) / 4u;
            if (r == 6u) { /* BSRR */
                g_gpio[p][5] = (g_gpio[p][5] | (v & 0xFFFFu)) & ~(v >> 16);
            } else if (r != 4u) {
                g_gpio[p][r] = v;
            }
            lines_update();
        }
    }
    world_step();
    mprotect((void *)WIN_BASE, WIN_SIZE, PROT_NONE);
}

/* --------------------------------------------------------------- the port's hooks ------ */

uint32_t timebase_now_us(void);
uint32_t timebase_now_us(void) {
    advance(CLOCK_NS);
    return (uint32_t)(g_now / 1000u);
}

void host_link_service(void) {
    advance(SERVICE_NS);
}

uint32_t irq_save(void);
void irq_restore(uint32_t primask);
uint32_t irq_save(void) {
    g_irq_depth++;
    return 0u;
}
void irq_restore(uint32_t primask) {
    (void)primask;
    if (g_irq_depth > 0) {
        g_irq_depth--;
    }
}

/* ---------------------------------------------------------------- scenarios ----------- */

static void setup(void) {
    void *m = mmap((void *)WIN_BASE, WIN_SIZE, PROT_NONE,
                   MAP_PRIVATE | MAP_ANONYMOUS | MAP_FIXED_NOREPLACE, -1, 0);
    if (m == MAP_FAILED) {
        perror("mmap");
        exit(2);
    }
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_flags = SA_SIGINFO | SA_NODEFER;
    sa.sa_sigaction = on_segv;
    sigaction(SIGSEGV, &sa, NULL);
    sa.sa_sigaction = on_trap;
    sigaction(SIGTRAP, &sa, NULL);
    for (unsigned k = 0; k < 3u; k++) {
        veml_reset(&g_bus[k]);
        g_bus[k].scl_line = g_bus[k].sda_line = 1;
    }
}

static int32_t xfer(uint8_t bus, uint8_t addr, const uint8_t *wr, uint32_t wl, uint8_t *rd,
                    uint32_t rl, uint32_t timeout_us) {
    const uint64_t t0 = g_now;
    const int32_t rc = i2c_transfer(bus, addr, wr, wl, rd, rl, timeout_us);
    printf("rc %d\n", (int)rc);
    printf("elapsed_us %llu\n", (unsigned long long)((g_now - t0) / 1000u));
    if (rc == STAC_I2C_OK && rl > 0u) {
        printf("data");
        for (uint32_t i = 0; i < rl; i++) {
            printf(" %02x", rd[i]);
        }
        printf("\n");
    }
    return rc;
}

static void read_reg(uint8_t bus, uint8_t reg) {
    uint8_t rd[2] = {0u, 0u};
    xfer(bus, VEML_ADDR, &reg, 1u, rd, 2u, 2000u);
}

static void write_conf(uint8_t bus, uint16_t v) {
    const uint8_t wr[3] = {0x00u, (uint8_t)v, (uint8_t)(v >> 8)};
    xfer(bus, VEML_ADDR, wr, 3u, NULL, 0u, 2000u);
}

/* A slave that was sending when the master went away (a reset mid-read): it drives the
 * bits of a 0x00 byte from `bit` on, and lets SDA go only at its acknowledge slot. */
static void hold_sda(bus_t *b, int bit) {
    b->tx_hold = 1;
    b->tx_byte = 0x00u;
    b->tx_bit = bit;
    b->rd_count = 0;
    lines_update();
}

int main(int argc, char **argv) {
    if (argc != 2) {
        fprintf(stderr, "usage: %s SCENARIO\n", argv[0]);
        return 2;
    }
    const char *s = argv[1];
    setup();
    bus_t *b0 = &g_bus[0];
    if (strcmp(s, "sda-stuck-at-init") == 0) {
        hold_sda(b0, 1);
    }
    if (strcmp(s, "scl-stuck") == 0) {
        b0->scl_stuck = 1;
        lines_update();
    }
    gpio_init_board();
    i2c_init_all(48000000u);
    if (strcmp(s, "plain") == 0) {
        read_reg(0, 0x0C);
        write_conf(0, 0x0008u);
        read_reg(0, 0x00);
        uint8_t one = 0u;
        const uint8_t reg = 0x0C;
        xfer(0, VEML_ADDR, &reg, 1u, &one, 1u, 2000u);
    } else if (strcmp(s, "nack") == 0) {
        b0->absent = 1;
        read_reg(0, 0x0C);
        b0->absent = 0;
        read_reg(0, 0x0C);
    } else if (strcmp(s, "berr") == 0) {
        b0->berr_in = 1;
        write_conf(0, 0x0008u);
        b0->berr_in = 2;
        read_reg(0, 0x00);
    } else if (strcmp(s, "arlo") == 0) {
        b0->arlo_next = 1;
        read_reg(0, 0x0C);
    } else if (strcmp(s, "sda-stuck-at-init") == 0) {
        read_reg(0, 0x0C);
    } else if (strcmp(s, "sda-stuck-later") == 0) {
        read_reg(0, 0x0C);
        hold_sda(b0, 3);
        b0->busy = 1;
        read_reg(0, 0x0C);
    } else if (strcmp(s, "irq-after-addr") == 0) {
        b0->irq_after_addr = 1;
        read_reg(0, 0x00); /* CONF, followed by the reserved 01h = 0x0000 */
        read_reg(0, 0x0C);
    } else if (strcmp(s, "scl-stuck") == 0) {
        read_reg(0, 0x0C);
    } else if (strcmp(s, "config") == 0) {
        /* nothing more: the set-up itself is checked */
    } else {
        fprintf(stderr, "unknown scenario %s\n", s);
        return 2;
    }
    mprotect((void *)WIN_BASE, WIN_SIZE, PROT_READ | PROT_WRITE);
    printf("fltr %u %u %u\n", (unsigned)g_bus[0].fltr, (unsigned)g_bus[1].fltr,
           (unsigned)g_bus[2].fltr);
    printf("ccr %u trise %u\n", (unsigned)g_bus[0].ccr, (unsigned)g_bus[0].trise);
    for (unsigned i = 0; i < BOARD_PIN_COUNT; i++) {
        const board_pin_t *p = &k_board_pins[i];
        const uint32_t *g = g_gpio[p->port == 'A' ? 0 : 1];
        printf("ospeed %s %u\n", p->signal, (unsigned)field2(g[2], p->pin));
    }
    printf("busy %d %d %d\n", g_bus[0].busy, g_bus[1].busy, g_bus[2].busy);
    printf("%s", g_log);
    return g_violations == 0u ? 0 : 1;
}
