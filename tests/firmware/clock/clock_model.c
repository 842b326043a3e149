/* Runs the port's real clock_init() natively against a register-level model of the STM32F411's
 * RCC, PWR and FLASH_ACR, one instruction at a time (tests/firmware/test_clock_model.py).
 *
 * The child maps anonymous memory at the peripherals' bus addresses, so clock.c and regs.h
 * compile unchanged, and stops itself under ptrace. The parent single-steps it; after every
 * instruction it reads the registers, sees each write as a change, and answers as the chip
 * would: ready flags follow their enables, the PLL locks only to a running source (PLLSRC: HSE
 * or HSI) and keeps PLLRDY a while after it is switched off (PLLCFGR may be written only once
 * it has stopped), SWS follows SW, a PWR write without the PWR clock or a VOS change with the PLL
 * running is ignored (RM0383 §5.4.1), VOSRDY comes once the PLL runs. Every rule the code
 * breaks is printed as "violation: ...", and on each switch to the PLL the clock tree (from the
 * source PLLSRC names) is held to the limits passed on the command line (from
 * datasheet_facts.toml).
 *
 *   clock_model FAULTS HCLK_MAX_SCALE1,2,3 WS_MAX0,1,2,3 APB1_MAX APB2_MAX \
 *               VCO_IN_MIN,MAX,VCO_MIN,MAX,Q_MIN,Q_MAX   (MHz; Q a divider)
 *   FAULTS: none, or a comma-separated set of no-hse (the crystal never starts), no-pll (the
 *   PLL never locks, from either source), no-vosrdy
 * Prints "result sys_hz apb1_hz apb2_hz tim_hz source usb_ok uart_brr" (the USART_BRR the port
 * computes from apb2_hz for BOARD_BAUD), "note TEXT" (the boot LOG's clock line, or "-"), the
 * final "state ..." and violations.
 *   clock_model notes   (stdin: lines "SOURCE APB2_HZ BAUD"; prints clock_note's text for each) */
#define _GNU_SOURCE
#include <fcntl.h>
#include <signal.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <sys/ptrace.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <unistd.h>

#include "clock.h"
#include "generated/board.h"
#include "regs.h"
#include "uart.h"

#define WINDOW_BASE 0x40000000ul
#define WINDOW_SIZE 0x30000ul /* APB1 (PWR at 0x4000_7000) to AHB1 (RCC, FLASH at 0x4002_3x00) */
#define DELAY_STEPS 40        /* instructions before a started oscillator or regulator is ready */
#define STOP_STEPS 400        /* instructions before a PLL switched off reports PLLRDY clear */
#define MAX_STEPS 20000000L

#define A_RCC_CR 0x40023800ul
#define A_RCC_PLLCFGR 0x40023804ul
#define A_RCC_CFGR 0x40023808ul
#define A_RCC_APB1ENR 0x40023840ul
#define A_PWR_CR 0x40007000ul
#define A_PWR_CSR 0x40007004ul
#define A_FLASH_ACR 0x40023C00ul

/* Reset values (RM0383): HSI on and ready; PWR_CR VOS = 10, scale 2. */
#define RESET_RCC_CR 0x00000083u
#define HSION (1u << 0)
#define HSI_MHZ 16.0
#define RESET_PWR_CR 0x00008000u

typedef struct {
    uint32_t cr, pllcfgr, cfgr, apb1enr, pwr_cr, pwr_csr, acr;
} snapshot_t;

static int g_mem = -1;
static unsigned g_violations;

static uint32_t peek(unsigned long addr) {
    uint32_t v = 0;
    if (pread(g_mem, &v, sizeof v, (off_t)addr) != (ssize_t)sizeof v) {
        perror("pread");
        exit(2);
    }
    return v;
}

static void poke(unsigned long addr, uint32_t v) {
    if (pwrite(g_mem, &v, sizeof v, (off_t)addr) != (ssize_t)sizeof v) {
        perror("pwrite");
        exit(2);
    }
}

static snapshot_t read_all(void) {
    snapshot_t s = {peek(A_RCC_CR), peek(A_RCC_PLLCFGR), peek(A_RCC_CFGR), peek(A_RCC_APB1ENR),
                    peek(A_PWR_CR), peek(A_PWR_CSR), peek(A_FLASH_ACR)};
    return s;
}

static void violation(const char *text, long step) {
    printf("violation: %s (instruction %ld)\n", text, step);
    g_violations++;
}

typedef struct {
    double hclk_max[4]; /* by scale 1..3, MHz */
    double ws_max[4];   /* HCLK limit for 0..3 wait states, MHz */
    double apb1_max, apb2_max;
    double pll[6]; /* VCO input min, max; VCO output min, max (MHz); PLLQ min, max */
} limits_t;

static const char *g_faults = "none";

/* 1 when FAULTS names `name` (a comma-separated list). */
static int fault(const char *name) {
    const size_t n = strlen(name);
    for (const char *f = g_faults; (f = strstr(f, name)) != NULL; f += n) {
        if ((f == g_faults || f[-1] == ',') && (f[n] == '\0' || f[n] == ',')) {
            return 1;
        }
    }
    return 0;
}

static unsigned ppre_div(uint32_t code) {
    return (code & 4u) != 0u ? 2u << (code & 3u) : 1u;
}

/* The clock tree as RCC is set: checked the moment SWS reports the PLL. */
static void check_switch(const snapshot_t *s, const limits_t *lim, long step) {
    const uint32_t m = s->pllcfgr & 0x3Fu, n = (s->pllcfgr >> 6) & 0x1FFu;
    const uint32_t p = (((s->pllcfgr >> 16) & 3u) + 1u) * 2u;
    const uint32_t q = (s->pllcfgr >> 24) & 0xFu;
    const double src_mhz = (s->pllcfgr & RCC_PLLCFGR_PLLSRC_HSE) != 0u ? BOARD_HSE_HZ / 1e6 : HSI_MHZ;
    const double vco_in = src_mhz / m, vco = vco_in * n;
    const double sys_mhz = vco / p;
    const uint32_t vos = (s->pwr_cr >> 14) & 3u;
    const int scale = vos == 3u ? 1 : vos == 2u ? 2 : 3;
    char text[200];
    if (vco_in < lim->pll[0] || vco_in > lim->pll[1] || vco < lim->pll[2] || vco > lim->pll[3]) {
        snprintf(text, sizeof text, "VCO input %.3f / VCO %.1f MHz outside their ranges", vco_in,
                 vco);
        violation(text, step);
    }
    if (q < lim->pll[4] || q > lim->pll[5]) {
        snprintf(text, sizeof text, "PLLQ %u is not a legal divider", (unsigned)q);
        violation(text, step);
    }
    if ((s->pllcfgr & RCC_PLLCFGR_PLLSRC_HSE) != 0u ? (s->cr & RCC_CR_HSERDY) == 0u
                                                     : (s->cr & RCC_CR_HSIRDY) == 0u) {
        violation("switched to a PLL whose source is not running", step);
    }
    if ((s->pwr_csr & PWR_CSR_VOSRDY) == 0u) {
        violation("switched to the PLL before VOSRDY", step);
    }
    if (sys_mhz > lim->hclk_max[scale]) {
        snprintf(text, sizeof text, "SYSCLK %.1f MHz above voltage scale %d's %.0f MHz", sys_mhz,
                 scale, lim->hclk_max[scale]);
        violation(text, step);
    }
    const uint32_t latency = s->acr & 7u;
    if (latency > 3u || sys_mhz > lim->ws_max[latency]) {
        snprintf(text, sizeof text, "%u flash wait states at %.1f MHz", latency, sys_mhz);
        violation(text, step);
    }
    const double apb1 = sys_mhz / ppre_div((s->cfgr >> 10) & 7u);
    const double apb2 = sys_mhz / ppre_div((s->cfgr >> 13) & 7u);
    if (apb1 > lim->apb1_max || apb2 > lim->apb2_max) {
        snprintf(text, sizeof text, "APB1 %.1f / APB2 %.1f MHz above their limits", apb1, apb2);
        violation(text, step);
    }
}

static void child(void) {
    void *m = mmap((void *)WINDOW_BASE, WINDOW_SIZE, PROT_READ | PROT_WRITE,
                   MAP_PRIVATE | MAP_ANONYMOUS | MAP_FIXED_NOREPLACE, -1, 0);
    if (m == MAP_FAILED) {
        _exit(3);
    }
    *(volatile uint32_t *)A_RCC_CR = RESET_RCC_CR;
    *(volatile uint32_t *)A_PWR_CR = RESET_PWR_CR;
    if (ptrace(PTRACE_TRACEME, 0, 0, 0) != 0) {
        _exit(4);
    }
    raise(SIGSTOP);
    clocks_t out;
    clock_init(&out);
    const char *note = clock_note(&out, BOARD_BAUD);
    printf("result %u %u %u %u %u %u %u\nnote %s\n", (unsigned)out.sys_hz,
           (unsigned)out.apb1_hz, (unsigned)out.apb2_hz, (unsigned)out.tim_hz,
           (unsigned)out.source, (unsigned)out.usb_ok,
           (unsigned)uart_brr(out.apb2_hz, BOARD_BAUD), note != NULL ? note : "-");
    fflush(stdout);
    _exit(0);
}

static void parse(const char *arg, double *out, int first, int count) {
    char *end = NULL;
    for (int i = first; i < count; i++) {
        out[i] = strtod(arg, &end);
        arg = *end == ',' ? end + 1 : end;
    }
}

/* "clock_model notes": for each stdin line "SOURCE APB2_HZ BAUD", clock_note's text (or "-"). */
static int notes(void) {
    unsigned source = 0, apb2 = 0, baud = 0;
    while (scanf("%u %u %u", &source, &apb2, &baud) == 3) {
        const clocks_t clk = {apb2, apb2, apb2, apb2, (uint8_t)source, 0u};
        const char *note = clock_note(&clk, baud);
        printf("%s\n", note != NULL ? note : "-");
    }
    return 0;
}

int main(int argc, char **argv) {
    if (argc == 2 && strcmp(argv[1], "notes") == 0) {
        return notes();
    }
    if (argc != 7) {
        fprintf(stderr, "usage: %s FAULTS HCLK1,2,3 WS0,1,2,3 APB1 APB2 PLL6\n", argv[0]);
        return 2;
    }
    g_faults = argv[1];
    limits_t lim = {{0}, {0}, atof(argv[4]), atof(argv[5]), {0}};
    parse(argv[2], lim.hclk_max, 1, 4);
    parse(argv[3], lim.ws_max, 0, 4);
    parse(argv[6], lim.pll, 0, 6);
    fflush(stdout);
    const pid_t pid = fork();
    if (pid == 0) {
        child();
    }
    int status = 0;
    waitpid(pid, &status, 0);
    if (!WIFSTOPPED(status)) {
        fprintf(stderr, "the child did not stop under ptrace (status %d)\n", status);
        return 2;
    }
    char path[64];
    snprintf(path, sizeof path, "/proc/%d/mem", (int)pid);
    g_mem = open(path, O_RDWR);
    if (g_mem < 0) {
        perror(path);
        return 2;
    }
    snapshot_t prev = read_all();
    long step = 0, hse_at = -1, pll_at = -1, vos_at = -1, pll_off_at = -1;
    for (; step < MAX_STEPS; step++) {
        if (ptrace(PTRACE_SINGLESTEP, pid, 0, 0) != 0) {
            perror("PTRACE_SINGLESTEP");
            return 2;
        }
        waitpid(pid, &status, 0);
        if (WIFEXITED(status)) {
            break;
        }
        snapshot_t s = read_all();
        /* PWR ignores writes without its clock, and VOS changes while the PLL runs. */
        if (s.pwr_cr != prev.pwr_cr) {
            if ((prev.apb1enr & RCC_APB1ENR_PWR) == 0u) {
                violation("PWR_CR written while the PWR clock is off (ignored)", step);
                s.pwr_cr = prev.pwr_cr;
            } else if (((s.pwr_cr ^ prev.pwr_cr) & PWR_CR_VOS_MASK) != 0u &&
                       (prev.cr & RCC_CR_PLLON) != 0u) {
                violation("VOS changed while the PLL runs (ignored)", step);
                s.pwr_cr = prev.pwr_cr;
            }
        }
        if (s.pllcfgr != prev.pllcfgr && (prev.cr & (RCC_CR_PLLON | RCC_CR_PLLRDY)) != 0u) {
            violation("PLLCFGR written while the PLL runs", step);
        }
        /* Oscillators, PLL and regulator answer DELAY_STEPS instructions after they start;
         * HSI (on from reset) is ready at once, and stops when switched off. */
        if ((s.cr & HSION) == 0u) {
            s.cr &= ~RCC_CR_HSIRDY;
        }
        if ((s.cr & RCC_CR_HSEON) == 0u) {
            hse_at = -1;
            s.cr &= ~RCC_CR_HSERDY;
        } else if (hse_at < 0) {
            hse_at = step;
        } else if (step - hse_at >= DELAY_STEPS && !fault("no-hse")) {
            s.cr |= RCC_CR_HSERDY;
        }
        /* A PLL switched off stops STOP_STEPS later: PLLRDY stays set until then. */
        if ((s.cr & RCC_CR_PLLON) == 0u) {
            pll_at = vos_at = -1;
            s.pwr_csr &= ~PWR_CSR_VOSRDY;
            if ((s.cr & RCC_CR_PLLRDY) == 0u) {
                pll_off_at = -1;
            } else if (pll_off_at < 0) {
                pll_off_at = step;
            } else if (step - pll_off_at >= STOP_STEPS) {
                s.cr &= ~RCC_CR_PLLRDY;
                pll_off_at = -1;
            }
        } else if (pll_at < 0) {
            pll_at = step;
        } else if (step - pll_at >= DELAY_STEPS && !fault("no-pll")) {
            /* The PLL locks to the source PLLSRC selects, and only while that one runs. */
            const uint32_t ready = (s.pllcfgr & RCC_PLLCFGR_PLLSRC_HSE) != 0u ? RCC_CR_HSERDY
                                                                              : RCC_CR_HSIRDY;
            if ((s.cr & ready) != 0u) {
                s.cr |= RCC_CR_PLLRDY;
            }
        }
        if ((s.cr & (RCC_CR_PLLON | RCC_CR_PLLRDY)) == (RCC_CR_PLLON | RCC_CR_PLLRDY) &&
            vos_at < 0) {
            vos_at = step;
        }
        if (vos_at >= 0 && step - vos_at >= DELAY_STEPS && !fault("no-vosrdy")) {
            s.pwr_csr |= PWR_CSR_VOSRDY;
        }
        /* SWS follows SW; the PLL can be selected only while it is ready. */
        uint32_t sw = s.cfgr & 3u;
        if (sw == RCC_CFGR_SW_PLL && (s.cr & RCC_CR_PLLRDY) == 0u) {
            sw = (s.cfgr & RCC_CFGR_SWS_MASK) >> 2;
        }
        s.cfgr = (s.cfgr & ~RCC_CFGR_SWS_MASK) | (sw << 2);
        if (((s.cfgr & RCC_CFGR_SWS_MASK) == RCC_CFGR_SWS_PLL) &&
            ((prev.cfgr & RCC_CFGR_SWS_MASK) != RCC_CFGR_SWS_PLL)) {
            check_switch(&s, &lim, step);
        }
        if ((s.cfgr & RCC_CFGR_SWS_MASK) == RCC_CFGR_SWS_PLL && (s.cr & RCC_CR_PLLON) == 0u) {
            violation("PLL turned off while it clocks the core", step);
        }
        poke(A_RCC_CR, s.cr);
        poke(A_RCC_CFGR, s.cfgr);
        poke(A_PWR_CR, s.pwr_cr);
        poke(A_PWR_CSR, s.pwr_csr);
        prev = s;
    }
    if (step >= MAX_STEPS) {
        kill(pid, SIGKILL);
        printf("violation: clock_init still running after %ld instructions\n", step);
        return 1;
    }
    printf("state sws=%u pllon=%u hseon=%u pllsrc=%u pllm=%u pllq=%u vos=%u latency=%u "
           "steps=%ld\n",
           (unsigned)((prev.cfgr & RCC_CFGR_SWS_MASK) >> 2), (unsigned)((prev.cr >> 24) & 1u),
           (unsigned)((prev.cr >> 16) & 1u), (unsigned)((prev.pllcfgr >> 22) & 1u),
           (unsigned)(prev.pllcfgr & 0x3Fu), (unsigned)((prev.pllcfgr >> 24) & 0xFu),
           (unsigned)((prev.pwr_cr >> 14) & 3u), (unsigned)(prev.acr & 7u), step);
    return g_violations == 0u ? 0 : 1;
}
