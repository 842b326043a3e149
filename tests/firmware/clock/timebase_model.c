/* The port's real timebase.c run natively against plain memory at the peripherals' bus
 * addresses (RCC, TIM5): what timebase_init leaves in the registers, printed for
 * tests/firmware/test_timebase.py, and the clock read across a stall in which the counter
 * (hardware, clocked on its own) advanced while no instruction ran. */
#define _GNU_SOURCE /* MAP_FIXED_NOREPLACE */
#include <stdio.h>
#include <sys/mman.h>

#include "regs.h"
#include "timebase.h"

#define WINDOW_BASE 0x40000000ul
#define WINDOW_SIZE 0x30000ul /* APB1 (TIM5 at 0x4000_0C00) to AHB1 (RCC at 0x4002_3800) */

int main(int argc, char **argv) {
    if (mmap((void *)WINDOW_BASE, WINDOW_SIZE, PROT_READ | PROT_WRITE,
             MAP_PRIVATE | MAP_ANONYMOUS | MAP_FIXED_NOREPLACE, -1, 0) == MAP_FAILED) {
        return 3;
    }
    unsigned long hz = 96000000ul;
    if (argc > 1 && sscanf(argv[1], "%lu", &hz) != 1) {
        return 2;
    }
    TIM5->CNT = 12345u; /* left over from before the reset */
    timebase_init((uint32_t)hz);
    printf("apb1enr %lu psc %lu arr %lu cnt %lu egr %lu cr1 %lu\n", (unsigned long)RCC->APB1ENR,
           (unsigned long)TIM5->PSC, (unsigned long)TIM5->ARR, (unsigned long)TIM5->CNT,
           (unsigned long)TIM5->EGR, (unsigned long)TIM5->CR1);
    const uint32_t before = timebase_now_us();
    TIM5->CNT = before + 7100000u; /* a four-sector erase stalls the core for 7.1 s */
    printf("across_stall %lu\n", (unsigned long)(timebase_now_us() - before));
    return 0;
}
