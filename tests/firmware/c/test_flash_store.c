/* The STM32F411 flash driver (firmware/ports/stm32f411/flash_store.c) against a fake FLASH
 * register block and a RAM "sector". The fake plays the controller from the driver's clock
 * reads (now_us), which the driver makes at the start of every wait: there it sees what the
 * driver asked for (STRT with SER/SNB/PSIZE, or a word written while PG), checks the control
 * register was unlocked and set as RM0383 section 3 says, carries the operation out (erase
 * to 0xFF; program clears bits only, as NOR flash does), raises BSY for a few polls and any
 * injected error flags, and treats a write to SR as write-1-to-clear.
 * What it cannot see: the order of the two FLASH_KEYR writes (only the last value stays). */
#include <stdbool.h>
#include <string.h>

#include "check.h"
#include "flash_store.h"
#include "stac_hal.h"

#define WORDS 256u

typedef struct {
    flash_regs_t regs;
    uint32_t mem[WORDS];
    uint32_t shadow[WORDS]; /* what the cells held at the last look */
    uint32_t sr;            /* SR as the controller set it (writes to SR clear bits) */
    uint32_t now;
    uint32_t busy_polls;    /* BSY stays this many more clock reads */
    uint32_t busy_len;      /* polls each operation keeps BSY */
    bool stuck;             /* BSY never clears */
    uint32_t inject;        /* SR error bits the next operation ends with */
    uint32_t erases, words; /* operations carried out */
    uint32_t bad_cr;        /* operations started with CR locked or set wrongly */
} fake_ctrl_t;

static fake_ctrl_t g_c;

static void start_op(fake_ctrl_t *c) {
    c->sr |= FLASH_SR_BSY;
    c->busy_polls = c->busy_len;
}

static uint32_t fake_now(void) {
    fake_ctrl_t *c = &g_c;
    c->now += 7u;
    if (c->regs.SR != c->sr) {
        c->sr &= ~(c->regs.SR & (FLASH_SR_ERRORS | FLASH_SR_EOP)); /* rc_w1 */
    }
    const uint32_t cr = c->regs.CR;
    const bool x32 = (cr & FLASH_CR_PSIZE_MASK) == FLASH_CR_PSIZE_X32;
    if ((c->sr & FLASH_SR_BSY) == 0u) {
        if ((cr & FLASH_CR_STRT) != 0u) {
            const uint32_t snb = (cr & FLASH_CR_SNB_MASK) >> FLASH_CR_SNB_SHIFT;
            if ((cr & FLASH_CR_LOCK) != 0u || (cr & FLASH_CR_SER) == 0u || snb != 7u || !x32 ||
                (cr & FLASH_CR_PG) != 0u) {
                c->bad_cr++;
            } else {
                memset(c->mem, 0xFF, sizeof c->mem);
                c->erases++;
            }
            c->regs.CR &= ~FLASH_CR_STRT;
            memcpy(c->shadow, c->mem, sizeof c->mem);
            start_op(c);
        } else {
            for (uint32_t i = 0u; i < WORDS; i++) {
                if (c->mem[i] == c->shadow[i]) {
                    continue;
                }
                if ((cr & FLASH_CR_PG) == 0u || (cr & FLASH_CR_LOCK) != 0u || !x32 ||
                    (cr & FLASH_CR_SER) != 0u) {
                    c->bad_cr++;
                    c->mem[i] = c->shadow[i]; /* a write without PG changes nothing */
                } else {
                    c->mem[i] &= c->shadow[i]; /* programming only clears bits */
                    c->words++;
                }
                c->shadow[i] = c->mem[i];
                start_op(c);
            }
        }
    } else if (!c->stuck && c->busy_polls > 0u && --c->busy_polls == 0u) {
        c->sr &= ~FLASH_SR_BSY;
        c->sr |= c->inject != 0u ? c->inject : FLASH_SR_EOP;
        c->inject = 0u;
    }
    c->regs.SR = c->sr;
    return c->now;
}

static flash_store_t setup(void) {
    memset(&g_c, 0, sizeof g_c);
    for (uint32_t i = 0u; i < WORDS; i++) {
        g_c.mem[i] = 0x12345678u * (i + 1u);
    }
    memcpy(g_c.shadow, g_c.mem, sizeof g_c.mem);
    g_c.busy_len = 3u;
    g_c.regs.ACR = 0x703u; /* 3 wait states, prefetch, I and D caches on (clock.c) */
    g_c.regs.CR = 0u;      /* unlocked: the fake cannot replay the key sequence */
    const flash_store_t f = {
        .regs = &g_c.regs,
        .base = g_c.mem,
        .size = WORDS * 4u,
        .sector = 7u,
        .now_us = fake_now,
    };
    return f;
}

/* After every operation: locked, no mode bits left, caches back on and not held in reset. */
static bool left_clean(void) {
    return (g_c.regs.CR & FLASH_CR_LOCK) != 0u &&
           (g_c.regs.CR & (FLASH_CR_PG | FLASH_CR_SER | FLASH_CR_SNB_MASK | FLASH_CR_STRT)) ==
               0u &&
           g_c.regs.ACR == 0x703u;
}

static void unlock_fake(void) {
    g_c.regs.CR &= ~FLASH_CR_LOCK; /* what the key sequence does on the real controller */
}

TEST(flash_erase_sets_ser_snb_psize_then_strt) {
    const flash_store_t f = setup();
    CHECK_EQ(flash_store_erase(&f), STAC_FLASH_OK);
    CHECK_EQ(g_c.erases, 1);
    CHECK_EQ(g_c.bad_cr, 0);
    for (uint32_t i = 0u; i < WORDS; i++) {
        CHECK_EQ(g_c.mem[i], 0xFFFFFFFFu);
    }
    CHECK(left_clean());
}

TEST(flash_program_writes_words_under_pg) {
    const flash_store_t f = setup();
    CHECK_EQ(flash_store_erase(&f), STAC_FLASH_OK);
    unlock_fake();
    const uint8_t data[8] = {0x01, 0x02, 0x03, 0x04, 0xA0, 0xB0, 0xC0, 0xD0};
    CHECK_EQ(flash_store_program(&f, 4u, data, sizeof data), STAC_FLASH_OK);
    CHECK_EQ(g_c.words, 2);
    CHECK_EQ(g_c.bad_cr, 0);
    CHECK_EQ(g_c.mem[0], 0xFFFFFFFFu);
    CHECK_EQ(g_c.mem[1], 0x04030201u);
    CHECK_EQ(g_c.mem[2], 0xD0C0B0A0u);
    CHECK_EQ(g_c.mem[3], 0xFFFFFFFFu);
    CHECK(left_clean());
}

TEST(flash_program_over_data_fails_its_read_back) {
    const flash_store_t f = setup();
    g_c.mem[0] = 0x0000FFFFu;
    memcpy(g_c.shadow, g_c.mem, sizeof g_c.mem);
    const uint8_t data[4] = {0x00, 0x00, 0xFF, 0xFF};
    CHECK_EQ(flash_store_program(&f, 0u, data, sizeof data), STAC_FLASH_FAILED);
    CHECK_EQ(g_c.mem[0], 0u);
    CHECK(left_clean());
}

TEST(flash_program_refuses_unaligned_or_outside) {
    const flash_store_t f = setup();
    const uint8_t data[8] = {0};
    CHECK_EQ(flash_store_program(&f, 2u, data, 4u), STAC_FLASH_BAD_ARG);
    CHECK_EQ(flash_store_program(&f, 0u, data, 3u), STAC_FLASH_BAD_ARG);
    CHECK_EQ(flash_store_program(&f, WORDS * 4u - 4u, data, 8u), STAC_FLASH_BAD_ARG);
    CHECK_EQ(flash_store_program(&f, 0xFFFFFFFCu, data, 8u), STAC_FLASH_BAD_ARG);
    CHECK_EQ(g_c.words + g_c.bad_cr, 0);
    CHECK_EQ(g_c.regs.CR, 0u); /* never touched */
}

TEST(flash_error_flags_fail_and_are_cleared_next_time) {
    const flash_store_t f = setup();
    g_c.inject = FLASH_SR_PGSERR;
    CHECK_EQ(flash_store_erase(&f), STAC_FLASH_FAILED);
    CHECK(left_clean());
    unlock_fake();
    CHECK_EQ(flash_store_erase(&f), STAC_FLASH_OK); /* the stale flag was cleared first */
    unlock_fake();
    g_c.inject = FLASH_SR_WRPERR;
    const uint8_t data[4] = {0};
    CHECK_EQ(flash_store_program(&f, 0u, data, 4u), STAC_FLASH_FAILED);
    CHECK(left_clean());
}

TEST(flash_stuck_busy_times_out) {
    const flash_store_t f = setup();
    g_c.stuck = true;
    CHECK_EQ(flash_store_erase(&f), STAC_FLASH_TIMEOUT);
    CHECK(g_c.now > FLASH_ERASE_TIMEOUT_US);
    CHECK(left_clean());
    unlock_fake();
    const uint32_t before = g_c.now;
    const uint8_t data[8] = {0};
    CHECK_EQ(flash_store_program(&f, 0u, data, 8u), STAC_FLASH_TIMEOUT);
    CHECK(g_c.now - before < 4u * FLASH_WORD_TIMEOUT_US); /* within the bound of one word */
}

TEST(flash_locked_controller_is_refused) {
    const flash_store_t f = setup();
    g_c.regs.CR = FLASH_CR_LOCK; /* the keys do not unlock this fake */
    const uint8_t data[4] = {0};
    CHECK_EQ(flash_store_program(&f, 0u, data, 4u), STAC_FLASH_FAILED);
    CHECK_EQ(g_c.regs.KEYR, FLASH_KEY2); /* the keys were written, the second one last */
    CHECK_EQ(g_c.words + g_c.bad_cr, 0);
    CHECK_EQ(flash_store_erase(&f), STAC_FLASH_FAILED);
    CHECK_EQ(g_c.erases + g_c.bad_cr, 0);
}

const test_case_t g_flash_store_tests[] = {
    {"flash_erase_sets_ser_snb_psize_then_strt", flash_erase_sets_ser_snb_psize_then_strt},
    {"flash_program_writes_words_under_pg", flash_program_writes_words_under_pg},
    {"flash_program_over_data_fails_its_read_back", flash_program_over_data_fails_its_read_back},
    {"flash_program_refuses_unaligned_or_outside", flash_program_refuses_unaligned_or_outside},
    {"flash_error_flags_fail_and_are_cleared_next_time",
     flash_error_flags_fail_and_are_cleared_next_time},
    {"flash_stuck_busy_times_out", flash_stuck_busy_times_out},
    {"flash_locked_controller_is_refused", flash_locked_controller_is_refused},
    {NULL, NULL},
};
