/* The STM32F411 flash driver (firmware/ports/stm32f411/flash_store.c) against a fake FLASH
 * register block and a RAM "store" cut into sectors. The fake plays the controller from the
 * driver's clock reads (now_us), which the driver makes at the start of every wait: there it
 * sees what the driver asked for (STRT with SER/SNB/PSIZE, or a word written while PG), checks
 * the control register was unlocked and set as RM0383 section 3 says and that SNB names a
 * sector of the store (never the program's sectors 0-3), carries the operation out (erase the
 * whole sector to 0xFF; program clears bits only, as NOR flash does), raises BSY for a few
 * polls and any injected error flags, and treats a write to SR as write-1-to-clear.
 * Two stores: a small one (sectors of 256, 512, 512 and 512 bytes, SNB 4-7: the real store's
 * 64 : 128 : 128 : 128 KiB) for the sequences, and the real sector table over 448 KiB of RAM
 * for the erases an image of a given size needs.
 * What it cannot see: the order of the two FLASH_KEYR writes (only the last value stays). */
#include <stdbool.h>
#include <string.h>

#include "check.h"
#include "flash_store.h"
#include "stac_hal.h"

#define SMALL_BYTES 1792u
#define BIG_WORDS (FLASH_STORE_SIZE / 4u)
#define MAX_OPS 16u

static const flash_sector_t k_small[4] = {
    {0u, 256u, 4u, 20000u},
    {256u, 512u, 5u, 40000u},
    {768u, 512u, 6u, 40000u},
    {1280u, 512u, 7u, 40000u},
};

static uint32_t g_small_mem[SMALL_BYTES / 4u], g_small_shadow[SMALL_BYTES / 4u];
static uint32_t g_big_mem[BIG_WORDS], g_big_shadow[BIG_WORDS];

typedef struct {
    flash_regs_t regs;
    const flash_store_t *f; /* the store under test: its memory and sector table */
    uint32_t *mem;
    uint32_t *shadow;       /* what the cells held at the last look */
    uint32_t words;
    uint32_t sr;            /* SR as the controller set it (writes to SR clear bits) */
    uint32_t now;
    uint32_t busy_polls;    /* BSY stays this many more clock reads */
    uint32_t busy_len;      /* polls each operation keeps BSY */
    bool stuck;             /* BSY never clears */
    uint32_t inject;        /* SR error bits operation number inject_op ends with */
    uint32_t inject_op;
    uint32_t ops;           /* operations started (erases and words) */
    uint32_t erases, programmed; /* operations carried out */
    uint32_t erased_snb[MAX_OPS];  /* SNB of each erase, in order */
    uint32_t kicks;                /* before_erase calls */
    uint32_t kick_at[MAX_OPS];     /* erases carried out when each kick came */
    uint32_t bad_cr;        /* operations started with CR locked or set wrongly */
} fake_ctrl_t;

static fake_ctrl_t g_c;

static void start_op(fake_ctrl_t *c) {
    c->sr |= FLASH_SR_BSY;
    c->busy_polls = c->busy_len;
    c->ops++;
}

static const flash_sector_t *sector_of(const fake_ctrl_t *c, uint32_t snb) {
    for (uint32_t k = 0u; k < c->f->n_sectors; k++) {
        if (c->f->sectors[k].snb == snb) {
            return &c->f->sectors[k];
        }
    }
    return NULL;
}

static void fake_erase(fake_ctrl_t *c, uint32_t cr, bool x32) {
    const uint32_t snb = (cr & FLASH_CR_SNB_MASK) >> FLASH_CR_SNB_SHIFT;
    const flash_sector_t *s = sector_of(c, snb);
    if ((cr & FLASH_CR_LOCK) != 0u || (cr & FLASH_CR_SER) == 0u || s == NULL || !x32 ||
        (cr & FLASH_CR_PG) != 0u) {
        c->bad_cr++;
    } else {
        memset(c->mem + s->offset / 4u, 0xFF, s->size);
        if (c->erases < MAX_OPS) {
            c->erased_snb[c->erases] = snb;
        }
        c->erases++;
    }
    c->regs.CR &= ~FLASH_CR_STRT;
    memcpy(c->shadow, c->mem, c->words * 4u);
    start_op(c);
}

static void fake_program(fake_ctrl_t *c, uint32_t cr, bool x32) {
    for (uint32_t i = 0u; i < c->words; i++) {
        if (c->mem[i] == c->shadow[i]) {
            continue;
        }
        if ((cr & FLASH_CR_PG) == 0u || (cr & FLASH_CR_LOCK) != 0u || !x32 ||
            (cr & FLASH_CR_SER) != 0u) {
            c->bad_cr++;
            c->mem[i] = c->shadow[i]; /* a write without PG changes nothing */
        } else {
            c->mem[i] &= c->shadow[i]; /* programming only clears bits */
            c->programmed++;
        }
        c->shadow[i] = c->mem[i];
        start_op(c);
    }
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
            fake_erase(c, cr, x32);
        } else {
            fake_program(c, cr, x32);
        }
    } else if (!c->stuck && c->busy_polls > 0u && --c->busy_polls == 0u) {
        c->sr &= ~FLASH_SR_BSY;
        c->sr |= c->inject != 0u && c->ops == c->inject_op ? c->inject : FLASH_SR_EOP;
    }
    c->regs.SR = c->sr;
    return c->now;
}

static void fake_kick(void) {
    if (g_c.kicks < MAX_OPS) {
        g_c.kick_at[g_c.kicks] = g_c.erases;
    }
    g_c.kicks++;
}

static flash_store_t g_f;

/* A store over `mem` with `sectors`, every word holding old data, the controller unlocked. */
static const flash_store_t *setup_over(uint32_t *mem, uint32_t *shadow, uint32_t bytes,
                                       const flash_sector_t *sectors, uint32_t n) {
    memset(&g_c, 0, sizeof g_c);
    for (uint32_t i = 0u; i < bytes / 4u; i++) {
        mem[i] = 0x12345678u * (i + 1u);
    }
    memcpy(shadow, mem, bytes);
    g_c.mem = mem;
    g_c.shadow = shadow;
    g_c.words = bytes / 4u;
    g_c.busy_len = 3u;
    g_c.regs.ACR = 0x703u; /* 3 wait states, prefetch, I and D caches on (clock.c) */
    g_c.regs.CR = 0u;      /* unlocked: the fake cannot replay the key sequence */
    g_f = (flash_store_t){
        .regs = &g_c.regs,
        .base = mem,
        .size = bytes,
        .sectors = sectors,
        .n_sectors = n,
        .now_us = fake_now,
        .before_erase = fake_kick,
    };
    g_c.f = &g_f;
    return &g_f;
}

static const flash_store_t *setup(void) {
    return setup_over(g_small_mem, g_small_shadow, SMALL_BYTES, k_small, 4u);
}

static const flash_store_t *setup_real_table(void) {
    return setup_over(g_big_mem, g_big_shadow, FLASH_STORE_SIZE, flash_store_sectors,
                      FLASH_STORE_SECTORS);
}

/* Operation number `op` from now ends with these SR error flags. */
static void inject(uint32_t flags, uint32_t op) {
    g_c.inject = flags;
    g_c.inject_op = g_c.ops + op;
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

/* Bit k set when sector k of the store reads erased, clear when it still holds old data;
 * 0xFFFFFFFF when a sector is neither. */
static uint32_t erased_sectors(const flash_store_t *f) {
    uint32_t mask = 0u;
    for (uint32_t k = 0u; k < f->n_sectors; k++) {
        const flash_sector_t *s = &f->sectors[k];
        uint32_t erased = 0u;
        for (uint32_t i = s->offset / 4u; i < (s->offset + s->size) / 4u; i++) {
            erased += g_c.mem[i] == 0xFFFFFFFFu ? 1u : 0u;
        }
        if (erased == s->size / 4u) {
            mask |= 1u << k;
        } else if (erased != 0u) {
            return 0xFFFFFFFFu;
        }
    }
    return mask;
}

/* Erase [offset, offset + len) of a fresh store: which sectors (bit k: sector k) it erased,
 * or 0xFFFFFFFF when the erase failed, an SNB was wrong or a watchdog kick did not come
 * right before each sector. */
static uint32_t erase_of(const flash_store_t *(*make)(void), uint32_t offset, uint32_t len) {
    const flash_store_t *f = make();
    if (flash_store_erase(f, offset, len) != STAC_FLASH_OK || g_c.bad_cr != 0u || !left_clean() ||
        g_c.kicks != g_c.erases) {
        return 0xFFFFFFFFu;
    }
    for (uint32_t k = 0u; k < g_c.kicks && k < MAX_OPS; k++) {
        if (g_c.kick_at[k] != k) {
            return 0xFFFFFFFFu;
        }
    }
    return erased_sectors(f);
}

TEST(flash_erase_sets_ser_snb_psize_then_strt_for_each_sector) {
    const flash_store_t *f = setup();
    CHECK_EQ(flash_store_erase(f, 0u, SMALL_BYTES), STAC_FLASH_OK);
    CHECK_EQ(g_c.erases, 4);
    CHECK_EQ(g_c.bad_cr, 0);
    for (uint32_t k = 0u; k < 4u; k++) {
        CHECK_EQ(g_c.erased_snb[k], 4u + k); /* in address order */
        CHECK_EQ(g_c.kick_at[k], k);         /* the watchdog refreshed before each sector */
    }
    CHECK_EQ(g_c.kicks, 4);
    CHECK_EQ(erased_sectors(f), 0xFu);
    CHECK(left_clean());
}

TEST(flash_erase_takes_only_the_sectors_a_range_touches) {
    CHECK_EQ(erase_of(setup, 0u, 4u), 0x1u);
    CHECK_EQ(erase_of(setup, 0u, 256u), 0x1u);
    CHECK_EQ(erase_of(setup, 252u, 8u), 0x3u); /* one word each side of a boundary */
    CHECK_EQ(erase_of(setup, 256u, 4u), 0x2u);
    CHECK_EQ(erase_of(setup, 300u, 900u), 0x6u);
    CHECK_EQ(erase_of(setup, SMALL_BYTES - 64u, 64u), 0x8u); /* the commit record's sector */
    const flash_store_t *f = setup();
    CHECK_EQ(flash_store_erase(f, 0u, 0u), STAC_FLASH_OK); /* nothing to erase */
    CHECK_EQ(g_c.erases + g_c.kicks, 0);
    CHECK_EQ(g_c.regs.CR, 0u); /* not even unlocked */
    CHECK_EQ(erased_sectors(f), 0u);
}

TEST(flash_erase_refuses_unaligned_or_outside) {
    const flash_store_t *f = setup();
    CHECK_EQ(flash_store_erase(f, 2u, 4u), STAC_FLASH_BAD_ARG);
    CHECK_EQ(flash_store_erase(f, 0u, 6u), STAC_FLASH_BAD_ARG);
    CHECK_EQ(flash_store_erase(f, 0u, SMALL_BYTES + 4u), STAC_FLASH_BAD_ARG);
    CHECK_EQ(flash_store_erase(f, SMALL_BYTES - 4u, 8u), STAC_FLASH_BAD_ARG);
    CHECK_EQ(flash_store_erase(f, 0xFFFFFFFCu, 8u), STAC_FLASH_BAD_ARG);
    CHECK_EQ(g_c.erases + g_c.bad_cr + g_c.kicks, 0);
    CHECK_EQ(g_c.regs.CR, 0u); /* never touched */
    CHECK_EQ(erased_sectors(f), 0u);
}

/* The real store (RM0383 table 4): sector 4 of 64 KiB at 0x0801_0000, then 5-7 of 128 KiB,
 * up to the end of the 512 KiB flash, each erase bounded by twice its datasheet maximum. */
TEST(flash_store_sectors_are_rm0383_sectors_4_to_7) {
    static const uint32_t addr[4] = {0x08010000u, 0x08020000u, 0x08040000u, 0x08060000u};
    static const uint32_t size[4] = {0x10000u, 0x20000u, 0x20000u, 0x20000u};
    static const uint32_t max_us[4] = {1100000u, 2000000u, 2000000u, 2000000u};
    uint32_t next = 0u;
    for (uint32_t k = 0u; k < FLASH_STORE_SECTORS; k++) {
        const flash_sector_t *s = &flash_store_sectors[k];
        CHECK_EQ(s->offset, next);
        CHECK_EQ(FLASH_STORE_ADDR + s->offset, addr[k]);
        CHECK_EQ(s->size, size[k]);
        CHECK_EQ(s->snb, 4u + k);
        CHECK_EQ(s->erase_timeout_us, 2u * max_us[k]);
        next += s->size;
    }
    CHECK_EQ(next, FLASH_STORE_SIZE);
    CHECK_EQ(FLASH_STORE_SIZE, 458752u);
    CHECK_EQ(FLASH_STORE_ADDR + FLASH_STORE_SIZE, 0x08080000u); /* the end of flash */
}

/* What MODEL_BEGIN asks of the real store (stac_model_store.c erases the image's words, then
 * the 64-byte record at the end unless that erase took it along). */
TEST(flash_erase_real_store_for_small_and_full_images) {
    const uint32_t record = FLASH_STORE_SIZE - 64u;
    CHECK_EQ(erase_of(setup_real_table, 0u, record), 0xFu); /* largest image: sectors 4-7 */
    CHECK_EQ(g_c.erases, 4);
    CHECK_EQ(erase_of(setup_real_table, 0u, 2968u), 0x1u); /* a small image: sector 4 alone */
    CHECK_EQ(g_c.erases, 1);
    CHECK_EQ(erase_of(setup_real_table, 0u, 65536u), 0x1u);
    CHECK_EQ(erase_of(setup_real_table, 0u, 117040u), 0x3u); /* paper i8: sectors 4-5 */
    CHECK_EQ(erase_of(setup_real_table, 0u, 426740u), 0xFu); /* paper f32: sectors 4-7 */
    CHECK_EQ(erase_of(setup_real_table, record, 64u), 0x8u); /* the record: sector 7 */
}

TEST(flash_program_writes_words_under_pg) {
    const flash_store_t *f = setup();
    CHECK_EQ(flash_store_erase(f, 0u, SMALL_BYTES), STAC_FLASH_OK);
    unlock_fake();
    const uint8_t data[8] = {0x01, 0x02, 0x03, 0x04, 0xA0, 0xB0, 0xC0, 0xD0};
    CHECK_EQ(flash_store_program(f, 4u, data, sizeof data), STAC_FLASH_OK);
    CHECK_EQ(g_c.programmed, 2);
    CHECK_EQ(g_c.bad_cr, 0);
    CHECK_EQ(g_c.mem[0], 0xFFFFFFFFu);
    CHECK_EQ(g_c.mem[1], 0x04030201u);
    CHECK_EQ(g_c.mem[2], 0xD0C0B0A0u);
    CHECK_EQ(g_c.mem[3], 0xFFFFFFFFu);
    CHECK(left_clean());
    /* Across a sector boundary too: programming does not care about sectors. */
    unlock_fake();
    CHECK_EQ(flash_store_program(f, 252u, data, sizeof data), STAC_FLASH_OK);
    CHECK_EQ(g_c.mem[63], 0x04030201u);
    CHECK_EQ(g_c.mem[64], 0xD0C0B0A0u);
}

TEST(flash_program_over_data_fails_its_read_back) {
    const flash_store_t *f = setup();
    g_c.mem[0] = 0x0000FFFFu;
    g_c.shadow[0] = g_c.mem[0];
    const uint8_t data[4] = {0x00, 0x00, 0xFF, 0xFF};
    CHECK_EQ(flash_store_program(f, 0u, data, sizeof data), STAC_FLASH_FAILED);
    CHECK_EQ(g_c.mem[0], 0u);
    CHECK(left_clean());
}

TEST(flash_program_refuses_unaligned_or_outside) {
    const flash_store_t *f = setup();
    const uint8_t data[8] = {0};
    CHECK_EQ(flash_store_program(f, 2u, data, 4u), STAC_FLASH_BAD_ARG);
    CHECK_EQ(flash_store_program(f, 0u, data, 3u), STAC_FLASH_BAD_ARG);
    CHECK_EQ(flash_store_program(f, SMALL_BYTES - 4u, data, 8u), STAC_FLASH_BAD_ARG);
    CHECK_EQ(flash_store_program(f, 0xFFFFFFFCu, data, 8u), STAC_FLASH_BAD_ARG);
    CHECK_EQ(g_c.programmed + g_c.bad_cr, 0);
    CHECK_EQ(g_c.regs.CR, 0u); /* never touched */
}

TEST(flash_error_flags_fail_and_are_cleared_next_time) {
    const flash_store_t *f = setup();
    inject(FLASH_SR_PGSERR, 1u);
    CHECK_EQ(flash_store_erase(f, 0u, 4u), STAC_FLASH_FAILED);
    CHECK(left_clean());
    unlock_fake();
    CHECK_EQ(flash_store_erase(f, 0u, 4u), STAC_FLASH_OK); /* the stale flag was cleared first */
    unlock_fake();
    inject(FLASH_SR_WRPERR, 1u);
    const uint8_t data[4] = {0};
    CHECK_EQ(flash_store_program(f, 0u, data, 4u), STAC_FLASH_FAILED);
    CHECK(left_clean());
}

/* A sector that fails ends the erase there: the sectors after it are not started. */
TEST(flash_erase_stops_at_the_first_failing_sector) {
    const flash_store_t *f = setup();
    inject(FLASH_SR_OPERR, 2u);
    CHECK_EQ(flash_store_erase(f, 0u, SMALL_BYTES), STAC_FLASH_FAILED);
    CHECK_EQ(g_c.erases, 2);
    CHECK_EQ(g_c.erased_snb[1], 5u);
    CHECK_EQ(erased_sectors(f), 0x3u);
    CHECK(left_clean());
}

TEST(flash_stuck_busy_times_out) {
    const flash_store_t *f = setup();
    g_c.stuck = true;
    CHECK_EQ(flash_store_erase(f, 0u, SMALL_BYTES), STAC_FLASH_TIMEOUT);
    CHECK(g_c.now > k_small[0].erase_timeout_us); /* the first sector's own bound */
    CHECK(g_c.now < k_small[0].erase_timeout_us + FLASH_WORD_TIMEOUT_US);
    CHECK_EQ(g_c.kicks, 1); /* no further sector was started */
    CHECK(left_clean());
    unlock_fake();
    const uint32_t before = g_c.now;
    const uint8_t data[8] = {0};
    CHECK_EQ(flash_store_program(f, 0u, data, 8u), STAC_FLASH_TIMEOUT);
    CHECK(g_c.now - before < 4u * FLASH_WORD_TIMEOUT_US); /* within the bound of one word */
}

TEST(flash_locked_controller_is_refused) {
    const flash_store_t *f = setup();
    g_c.regs.CR = FLASH_CR_LOCK; /* the keys do not unlock this fake */
    const uint8_t data[4] = {0};
    CHECK_EQ(flash_store_program(f, 0u, data, 4u), STAC_FLASH_FAILED);
    CHECK_EQ(g_c.regs.KEYR, FLASH_KEY2); /* the keys were written, the second one last */
    CHECK_EQ(g_c.programmed + g_c.bad_cr, 0);
    CHECK_EQ(flash_store_erase(f, 0u, SMALL_BYTES), STAC_FLASH_FAILED);
    CHECK_EQ(g_c.erases + g_c.bad_cr + g_c.kicks, 0);
}

const test_case_t g_flash_store_tests[] = {
    {"flash_erase_sets_ser_snb_psize_then_strt_for_each_sector",
     flash_erase_sets_ser_snb_psize_then_strt_for_each_sector},
    {"flash_erase_takes_only_the_sectors_a_range_touches",
     flash_erase_takes_only_the_sectors_a_range_touches},
    {"flash_erase_refuses_unaligned_or_outside", flash_erase_refuses_unaligned_or_outside},
    {"flash_store_sectors_are_rm0383_sectors_4_to_7", flash_store_sectors_are_rm0383_sectors_4_to_7},
    {"flash_erase_real_store_for_small_and_full_images",
     flash_erase_real_store_for_small_and_full_images},
    {"flash_program_writes_words_under_pg", flash_program_writes_words_under_pg},
    {"flash_program_over_data_fails_its_read_back", flash_program_over_data_fails_its_read_back},
    {"flash_program_refuses_unaligned_or_outside", flash_program_refuses_unaligned_or_outside},
    {"flash_error_flags_fail_and_are_cleared_next_time",
     flash_error_flags_fail_and_are_cleared_next_time},
    {"flash_erase_stops_at_the_first_failing_sector",
     flash_erase_stops_at_the_first_failing_sector},
    {"flash_stuck_busy_times_out", flash_stuck_busy_times_out},
    {"flash_locked_controller_is_refused", flash_locked_controller_is_refused},
    {NULL, NULL},
};
