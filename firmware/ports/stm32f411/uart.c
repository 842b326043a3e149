#include "uart.h"

#include <stdbool.h>

#include "irq.h"
#include "regs.h"

#define TX_SIZE 2048u /* power of two; several full frames */
#define RX_SIZE 512u  /* power of two; ~5 ms of input at 921600 baud */

static uint8_t g_tx[TX_SIZE];
static volatile uint32_t g_tx_head; /* written by the main context */
static volatile uint32_t g_tx_tail; /* written by the interrupt, or by uart_service with it masked */
static uint8_t g_rx[RX_SIZE];
static volatile uint32_t g_rx_head; /* written by the interrupt */
static volatile uint32_t g_rx_tail; /* written by the main context */
static volatile uint32_t g_rx_lost;

/* Hand the next queued byte to the transmitter; false when the ring is empty. Interrupt
 * context, or the main context with interrupts masked. */
static bool tx_next(void) {
    const uint32_t tail = g_tx_tail;
    if (tail == g_tx_head) {
        return false;
    }
    USART1->DR = g_tx[tail % TX_SIZE];
    g_tx_tail = tail + 1u;
    return true;
}

/* Transmission runs from the TXE interrupt, so a frame leaves while the superloop is busy
 * (decoding takes ~10-15 ms, longer than a SAMPLE frame's ~0.6 ms on the wire). */
void USART1_IRQHandler(void) {
    const uint32_t sr = USART1->SR;
    if ((sr & USART_SR_TXE) != 0u && (USART1->CR1 & USART_CR1_TXEIE) != 0u && !tx_next()) {
        USART1->CR1 &= ~USART_CR1_TXEIE; /* empty: uart_write enables it again */
    }
    if ((sr & (USART_SR_RXNE | USART_SR_ORE)) != 0u) {
        const uint8_t byte = (uint8_t)USART1->DR; /* also clears ORE after the SR read */
        if ((sr & USART_SR_ORE) != 0u) {
            g_rx_lost++;
        }
        const uint32_t head = g_rx_head;
        if (head - g_rx_tail < RX_SIZE) {
            g_rx[head % RX_SIZE] = byte;
            g_rx_head = head + 1u;
        } else {
            g_rx_lost++;
        }
    }
}

void uart_init(uint32_t apb2_hz, uint32_t baud) {
    RCC->APB2ENR |= RCC_APB2ENR_USART1;
    (void)RCC->APB2ENR;
    USART1->CR1 = 0u;
    USART1->BRR = uart_brr(apb2_hz, baud);
    USART1->CR1 = USART_CR1_UE | USART_CR1_TE | USART_CR1_RE | USART_CR1_RXNEIE;
    irq_enable(USART1_IRQN, IRQ_PRIORITY_LINK);
}

uint32_t uart_write(const uint8_t *data, uint32_t len) {
    const uint32_t head = g_tx_head;
    if (TX_SIZE - (head - g_tx_tail) < len) {
        uart_service();
        if (TX_SIZE - (head - g_tx_tail) < len) {
            return 0u;
        }
    }
    for (uint32_t i = 0; i < len; i++) {
        g_tx[(head + i) % TX_SIZE] = data[i];
    }
    g_tx_head = head + len; /* before TXEIE: the interrupt then never sees an empty ring */
    USART1->CR1 |= USART_CR1_TXEIE;
    uart_service();
    return len;
}

uint32_t uart_read(uint8_t *buf, uint32_t cap) {
    uint32_t n = 0u;
    uint32_t tail = g_rx_tail;
    const uint32_t head = g_rx_head;
    while (tail != head && n < cap) {
        buf[n++] = g_rx[tail % RX_SIZE];
        tail++;
    }
    g_rx_tail = tail;
    return n;
}

/* Also moves bytes from the main context while the transmitter has room: where no TXE
 * interrupt comes (QEMU's USART raises none; its transmitter is always empty) this is what
 * sends. Interrupts are masked meanwhile, so the tail has one writer at a time. */
void uart_service(void) {
    uint32_t primask;
    __asm volatile("mrs %0, primask\n\tcpsid i" : "=r"(primask)::"memory");
    while ((USART1->SR & USART_SR_TXE) != 0u && tx_next()) {
    }
    __asm volatile("msr primask, %0" ::"r"(primask) : "memory");
}

uint32_t uart_rx_lost(void) {
    return g_rx_lost;
}

uint32_t uart_tx_queued(void) {
    return g_tx_head - g_tx_tail;
}

int uart_tx_done(void) {
    return (USART1->SR & USART_SR_TC) != 0u;
}
