/* The STM32F411 registers this port touches (RM0383). No vendor headers exist on our build
 * machines, so each peripheral is declared here as a struct at its bus address.
 *
 * Every address, offset and bit below is checked against ST's own description of the chip
 * (the STM32F411xx SVD) by tests/firmware/test_regs_svd.py, which finds the macros by parsing
 * this file: name them PERIPHERAL_REGISTER_FIELD[_VALUE|_SHIFT|_MASK] so the check can place
 * them. Core registers (SysTick, SCB) are not in ST's SVD and are checked against the ARMv7-M
 * facts in hardware/datasheet_facts.toml instead. */
#ifndef STM32F411_REGS_H
#define STM32F411_REGS_H

#include <stdint.h>

#define REG32(addr) (*(volatile uint32_t *)(addr))

typedef struct {
    volatile uint32_t CR, PLLCFGR, CFGR, CIR, AHB1RSTR, AHB2RSTR, RES0[2], APB1RSTR, APB2RSTR,
        RES1[2], AHB1ENR, AHB2ENR, RES2[2], APB1ENR, APB2ENR, RES3[2], AHB1LPENR, AHB2LPENR,
        RES4[2], APB1LPENR, APB2LPENR, RES5[2], BDCR, CSR;
} rcc_t;
#define RCC ((rcc_t *)0x40023800u)
#define RCC_CR_HSIRDY (1u << 1)
#define RCC_CR_HSEON (1u << 16)
#define RCC_CR_HSERDY (1u << 17)
#define RCC_CR_PLLON (1u << 24)
#define RCC_CR_PLLRDY (1u << 25)
#define RCC_PLLCFGR_PLLM_SHIFT 0u
#define RCC_PLLCFGR_PLLN_SHIFT 6u
#define RCC_PLLCFGR_PLLP_SHIFT 16u
#define RCC_PLLCFGR_PLLSRC_HSE (1u << 22)
#define RCC_PLLCFGR_PLLQ_SHIFT 24u
#define RCC_CFGR_SW_PLL 2u
#define RCC_CFGR_SWS_MASK (3u << 2)
#define RCC_CFGR_SWS_PLL (2u << 2)
#define RCC_CFGR_PPRE1_DIV2 (4u << 10)
#define RCC_AHB1ENR_GPIOA (1u << 0)
#define RCC_AHB1ENR_GPIOB (1u << 1)
#define RCC_APB1ENR_TIM2 (1u << 0)
#define RCC_APB1ENR_TIM3 (1u << 1)
#define RCC_APB1ENR_TIM4 (1u << 2)
#define RCC_APB1ENR_TIM5 (1u << 3)
#define RCC_APB1ENR_I2C1 (1u << 21)
#define RCC_APB1ENR_I2C2 (1u << 22)
#define RCC_APB1ENR_I2C3 (1u << 23)
#define RCC_APB1ENR_PWR (1u << 28)
#define RCC_APB2ENR_USART1 (1u << 4)
#define RCC_APB2ENR_SYSCFG (1u << 14)
/* Reset flags (RM0383 §6.3.21 RCC_CSR), kept until RMVF clears them. ST's SVD names the pin
 * flag PADRSTF (the manual: PINRSTF) and the independent watchdog's WDGRSTF (IWDGRSTF). */
#define RCC_CSR_RMVF (1u << 24)
#define RCC_CSR_BORRSTF (1u << 25)
#define RCC_CSR_PADRSTF (1u << 26)
#define RCC_CSR_PORRSTF (1u << 27)
#define RCC_CSR_SFTRSTF (1u << 28)
#define RCC_CSR_WDGRSTF (1u << 29)
#define RCC_CSR_WWDGRSTF (1u << 30)
#define RCC_CSR_LPWRRSTF (1u << 31)
#define RCC_AHB2ENR_OTGFS (1u << 7)
#define RCC_AHB2RSTR_OTGFS (1u << 7)

/* Power controller (RM0383 §5.4): regulator voltage scale. */
typedef struct {
    volatile uint32_t CR, CSR;
} pwr_t;
#define PWR ((pwr_t *)0x40007000u)
#define PWR_CR_VOS_MASK (3u << 14)
#define PWR_CR_VOS_SCALE1 (3u << 14)
#define PWR_CSR_VOSRDY (1u << 14)

#define FLASH_ACR REG32(0x40023C00u)
#define FLASH_ACR_LATENCY_MASK 7u
#define FLASH_ACR_LATENCY_3WS 3u
#define FLASH_ACR_PRFTEN (1u << 8)
#define FLASH_ACR_ICEN (1u << 9)
#define FLASH_ACR_DCEN (1u << 10)

typedef struct {
    volatile uint32_t MODER, OTYPER, OSPEEDR, PUPDR, IDR, ODR, BSRR, LCKR, AFR[2];
} gpio_t;
#define GPIOA ((gpio_t *)0x40020000u)
#define GPIOB ((gpio_t *)0x40020400u)
/* Pin 0's fields and codes; pin n's sit n times the field's width up (AFRL/AFRH: n % 8). */
#define GPIO_MODER_MODER0_MASK 3u
#define GPIO_MODER_MODER0_OUTPUT 1u
#define GPIO_MODER_MODER0_AF 2u
#define GPIO_OTYPER_OT0 (1u << 0)
#define GPIO_OSPEEDR_OSPEEDR0_MASK 3u
#define GPIO_OSPEEDR_OSPEEDR0_FAST 2u
#define GPIO_OSPEEDR_OSPEEDR0_VERYHIGH 3u
#define GPIO_PUPDR_PUPDR0_MASK 3u
#define GPIO_PUPDR_PUPDR0_PULLUP 1u
#define GPIO_AFRL_AFRL0_MASK 0xFu
#define GPIO_BSRR_BS0 (1u << 0)
#define GPIO_BSRR_BR0 (1u << 16)

typedef struct {
    volatile uint32_t CR1, CR2, OAR1, OAR2, DR, SR1, SR2, CCR, TRISE, FLTR;
} i2c_t;
#define I2C1 ((i2c_t *)0x40005400u)
#define I2C2 ((i2c_t *)0x40005800u)
#define I2C3 ((i2c_t *)0x40005C00u)
#define I2C_CR1_PE (1u << 0)
#define I2C_CR1_START (1u << 8)
#define I2C_CR1_STOP (1u << 9)
#define I2C_CR1_ACK (1u << 10)
#define I2C_CR1_POS (1u << 11)
#define I2C_CR1_SWRST (1u << 15)
#define I2C_SR1_SB (1u << 0)
#define I2C_SR1_ADDR (1u << 1)
#define I2C_SR1_BTF (1u << 2)
#define I2C_SR1_RXNE (1u << 6)
#define I2C_SR1_TXE (1u << 7)
#define I2C_SR1_BERR (1u << 8)
#define I2C_SR1_ARLO (1u << 9)
#define I2C_SR1_AF (1u << 10)
#define I2C_SR2_BUSY (1u << 1)
#define I2C_CCR_FS (1u << 15)
/* I2C_FLTR is RM0383's alone (ST's SVD lacks it): checked against the manual's bits. */
#define I2C_FLTR_DNF_MASK 0xFu
#define I2C_FLTR_ANOFF (1u << 4)

/* General-purpose timers TIM2..TIM4 (RM0383 §13.4): no RCR (0x30) or BDTR (0x44) there, and
 * only TIM2 has OR (0x50), which the port leaves alone. */
typedef struct {
    volatile uint32_t CR1, CR2, SMCR, DIER, SR, EGR, CCMR1, CCMR2, CCER, CNT, PSC, ARR, RES0,
        CCR[4], RES1, DCR, DMAR;
} tim_t;
#define TIM2 ((tim_t *)0x40000000u)
#define TIM3 ((tim_t *)0x40000400u)
#define TIM4 ((tim_t *)0x40000800u)
#define TIM5 ((tim_t *)0x40000C00u) /* 32-bit: the port's microsecond clock (timebase.c) */
#define TIM_CR1_CEN (1u << 0)
#define TIM_CR1_ARPE (1u << 7)
#define TIM_EGR_UG (1u << 0)
/* Channel 1's fields; channel n's sit (n-1) % 2 * 8 bits up in CCMR1/CCMR2 and (n-1) * 4 bits
 * up in CCER. */
#define TIM_CCMR1_CC1S_MASK (3u << 0)
#define TIM_CCMR1_OC1FE (1u << 2)
#define TIM_CCMR1_OC1PE (1u << 3)
#define TIM_CCMR1_OC1M_MASK (7u << 4)
#define TIM_CCMR1_OC1M_PWM1 (6u << 4)
#define TIM_CCMR1_OC1CE (1u << 7)
#define TIM_CCMR1_CH1_MASK \
    (TIM_CCMR1_CC1S_MASK | TIM_CCMR1_OC1FE | TIM_CCMR1_OC1PE | TIM_CCMR1_OC1M_MASK | TIM_CCMR1_OC1CE)
#define TIM_CCER_CC1E (1u << 0)
#define TIM_CCER_CC1P (1u << 1)

typedef struct {
    volatile uint32_t SR, DR, BRR, CR1, CR2, CR3, GTPR;
} usart_t;
#define USART1 ((usart_t *)0x40011000u)
#define USART_SR_ORE (1u << 3)
#define USART_SR_RXNE (1u << 5)
#define USART_SR_TC (1u << 6)
#define USART_SR_TXE (1u << 7)
#define USART_CR1_RE (1u << 2)
#define USART_CR1_TE (1u << 3)
#define USART_CR1_RXNEIE (1u << 5)
#define USART_CR1_TXEIE (1u << 7)
#define USART_CR1_UE (1u << 13)
#define USART1_IRQN 37u

typedef struct {
    volatile uint32_t CSR, RVR, CVR, CALIB;
} systick_t;
#define SYSTICK ((systick_t *)0xE000E010u)
#define SYSTICK_CSR_ENABLE (1u << 0)
#define SYSTICK_CSR_TICKINT (1u << 1)
#define SYSTICK_CSR_CLKSOURCE (1u << 2)

#define NVIC_ISER(n) REG32(0xE000E100u + 4u * (n))
#define NVIC_ISPR(n) REG32(0xE000E200u + 4u * (n))
#define NVIC_IPR(n) REG32(0xE000E400u + 4u * (n)) /* four 8-bit priorities per word */
#define SCB_CPACR REG32(0xE000ED88u)
#define SCB_CPACR_CP10_CP11_FULL (0xFu << 20)
#define SCB_CCR REG32(0xE000ED14u)
#define SCB_CCR_BFHFNMIGN (1u << 8)
#define SCB_CFSR REG32(0xE000ED28u)
#define SCB_HFSR REG32(0xE000ED2Cu)
#define SCB_MMFAR REG32(0xE000ED34u)
#define SCB_BFAR REG32(0xE000ED38u)
#define SCB_AIRCR REG32(0xE000ED0Cu)
#define SCB_AIRCR_RESET 0x05FA0004u

typedef struct {
    volatile uint32_t KR, PR, RLR, SR;
} iwdg_t;
#define IWDG ((iwdg_t *)0x40003000u)
#define IWDG_KR_RELOAD 0xAAAAu
#define IWDG_KR_UNLOCK 0x5555u
#define IWDG_KR_START 0xCCCCu
#define IWDG_SR_PVU (1u << 0)
#define IWDG_SR_RVU (1u << 1)

#define UID_BASE 0x1FFF7A10u
/* The system memory: ST's ROM bootloader (USB DFU among others), its vector table first. */
#define SYSTEM_MEMORY_BASE 0x1FFF0000u

/* Debug support (RM0383 §23.16.4 DBGMCU_APB1_FZ): stop the independent watchdog while the core
 * is halted by a debugger. ST's SVD spells the field DBG_IWDEG_STOP. */
#define DBG_DBGMCU_APB1_FZ REG32(0xE0042008u)
#define DBG_DBGMCU_APB1_FZ_DBG_IWDEG_STOP (1u << 12)

/* System configuration (RM0383 §7.2.1 SYSCFG_MEMRMP): MEM_MODE 01 maps the system memory (the
 * ROM bootloader) at 0. */
#define SYSCFG_MEMRM REG32(0x40013800u)
#define SYSCFG_MEMRM_MEM_MODE_SYSTEM 1u

/* USB on-the-go full speed (RM0383 chapter 22, OTG_FS register map), device mode only; offsets
 * from the block's base 0x5000_0000. */
#define OTG_FS_BASE 0x50000000u
#define OTG_FS_IRQN 67u
#define OTG_GOTGCTL REG32(OTG_FS_BASE + 0x000u)
#define OTG_GAHBCFG REG32(OTG_FS_BASE + 0x008u)
#define OTG_GUSBCFG REG32(OTG_FS_BASE + 0x00Cu)
#define OTG_GRSTCTL REG32(OTG_FS_BASE + 0x010u)
#define OTG_GINTSTS REG32(OTG_FS_BASE + 0x014u)
#define OTG_GINTMSK REG32(OTG_FS_BASE + 0x018u)
#define OTG_GRXSTSP REG32(OTG_FS_BASE + 0x020u)
#define OTG_GRXFSIZ REG32(OTG_FS_BASE + 0x024u)
#define OTG_DIEPTXF0 REG32(OTG_FS_BASE + 0x028u) /* HNPTXFSIZ in host mode */
#define OTG_GCCFG REG32(OTG_FS_BASE + 0x038u)
#define OTG_DIEPTXF(n) REG32(OTG_FS_BASE + 0x104u + 4u * ((n) - 1u)) /* n = 1..3 */
#define OTG_DCFG REG32(OTG_FS_BASE + 0x800u)
#define OTG_DCTL REG32(OTG_FS_BASE + 0x804u)
#define OTG_DSTS REG32(OTG_FS_BASE + 0x808u)
#define OTG_DIEPMSK REG32(OTG_FS_BASE + 0x810u)
#define OTG_DOEPMSK REG32(OTG_FS_BASE + 0x814u)
#define OTG_DAINT REG32(OTG_FS_BASE + 0x818u)
#define OTG_DAINTMSK REG32(OTG_FS_BASE + 0x81Cu)
#define OTG_DIEPCTL(n) REG32(OTG_FS_BASE + 0x900u + 0x20u * (n))
#define OTG_DIEPINT(n) REG32(OTG_FS_BASE + 0x908u + 0x20u * (n))
#define OTG_DIEPTSIZ(n) REG32(OTG_FS_BASE + 0x910u + 0x20u * (n))
#define OTG_DTXFSTS(n) REG32(OTG_FS_BASE + 0x918u + 0x20u * (n))
#define OTG_DOEPCTL(n) REG32(OTG_FS_BASE + 0xB00u + 0x20u * (n))
#define OTG_DOEPINT(n) REG32(OTG_FS_BASE + 0xB08u + 0x20u * (n))
#define OTG_DOEPTSIZ(n) REG32(OTG_FS_BASE + 0xB10u + 0x20u * (n))
#define OTG_PCGCCTL REG32(OTG_FS_BASE + 0xE00u)
#define OTG_FIFO(n) REG32(OTG_FS_BASE + 0x1000u + 0x1000u * (n)) /* push TX n / pop RX */

#define OTG_GAHBCFG_GINTMSK (1u << 0)
#define OTG_GUSBCFG_PHYSEL (1u << 6)
#define OTG_GUSBCFG_TRDT_SHIFT 10u
#define OTG_GUSBCFG_TRDT_MASK (0xFu << 10)
#define OTG_GUSBCFG_FDMOD (1u << 30)
#define OTG_GRSTCTL_CSRST (1u << 0)
#define OTG_GRSTCTL_RXFFLSH (1u << 4)
#define OTG_GRSTCTL_TXFFLSH (1u << 5)
#define OTG_GRSTCTL_TXFNUM_SHIFT 6u
#define OTG_GRSTCTL_AHBIDL (1u << 31)
#define OTG_GINT_RXFLVL (1u << 4)
#define OTG_GINT_USBSUSP (1u << 11)
#define OTG_GINT_USBRST (1u << 12)
#define OTG_GINT_ENUMDNE (1u << 13)
#define OTG_GINT_IEPINT (1u << 18)
#define OTG_GINT_OEPINT (1u << 19)
#define OTG_GINT_WKUPINT (1u << 31)
#define OTG_GRXSTSP_EPNUM_MASK 0xFu
#define OTG_GRXSTSP_BCNT_SHIFT 4u
#define OTG_GRXSTSP_BCNT_MASK (0x7FFu << 4)
#define OTG_GRXSTSP_PKTSTS_SHIFT 17u
#define OTG_GRXSTSP_PKTSTS_MASK (0xFu << 17)
#define OTG_PKTSTS_OUT_DATA 2u
#define OTG_PKTSTS_SETUP_DATA 6u
#define OTG_GCCFG_PWRDWN (1u << 16)
#define OTG_GCCFG_VBUSASEN (1u << 18)
#define OTG_GCCFG_VBUSBSEN (1u << 19)
#define OTG_GCCFG_NOVBUSSENS (1u << 21)
#define OTG_DCFG_DSPD_FS 3u
#define OTG_DCFG_DAD_SHIFT 4u
#define OTG_DCFG_DAD_MASK (0x7Fu << 4)
#define OTG_DIEPTXF0_TX0FD_SHIFT 16u
#define OTG_DIEPTXF_INEPTXFD_SHIFT 16u
#define OTG_DAINT_IEPINT_MASK 0xFFFFu
#define OTG_DAINT_OEPINT_SHIFT 16u
#define OTG_DAINTMSK_OEPM_SHIFT 16u
#define OTG_DCTL_SDIS (1u << 1)
#define OTG_DCTL_CGINAK (1u << 8)
#define OTG_DIEPCTL0_MPSIZ_MASK 3u
#define OTG_EPCTL_USBAEP (1u << 15)
#define OTG_EPCTL_EPTYP_SHIFT 18u
#define OTG_EPCTL_STALL (1u << 21)
#define OTG_EPCTL_TXFNUM_SHIFT 22u
#define OTG_EPCTL_CNAK (1u << 26)
#define OTG_EPCTL_SNAK (1u << 27)
#define OTG_EPCTL_SD0PID (1u << 28)
#define OTG_EPCTL_EPDIS (1u << 30)
#define OTG_EPCTL_EPENA (1u << 31)
#define OTG_EPINT_XFRC (1u << 0)
#define OTG_EPINT_EPDISD (1u << 1)
#define OTG_DOEPINT_STUP (1u << 3)
#define OTG_TSIZ_PKTCNT_SHIFT 19u
#define OTG_PCGCCTL_STPPCLK (1u << 0) /* stop the PHY clock while the bus is suspended */
#define OTG_DOEPTSIZ0_STUPCNT_SHIFT 29u

#endif /* STM32F411_REGS_H */
