/* Minimal unit-test harness: TEST(name) functions registered in a table per file, run by
 * test_main.c one at a time (by name) so that pytest reports each C test separately. */
#ifndef CHECK_H
#define CHECK_H

#include <stddef.h>
#include <stdio.h>

typedef void (*test_fn_t)(void);
typedef struct test_case {
    const char *name;
    test_fn_t fn;
} test_case_t;

extern int g_check_failed;

/* Runs the tests of `tables` (check_runner.c): all, `--list`, or the one named `only`. */
int check_main(const test_case_t *const *tables, size_t n_tables, const char *only);

#define TEST(name) static void name(void)

#define CHECK(cond)                                                                      \
    do {                                                                                 \
        if (!(cond)) {                                                                   \
            printf("%s:%d: check failed: %s\n", __FILE__, __LINE__, #cond);              \
            g_check_failed = 1;                                                          \
            return;                                                                      \
        }                                                                                \
    } while (0)

#define CHECK_EQ(a, b)                                                                   \
    do {                                                                                 \
        const long long check_a_ = (long long)(a);                                       \
        const long long check_b_ = (long long)(b);                                       \
        if (check_a_ != check_b_) {                                                      \
            printf("%s:%d: check failed: %s == %s (%lld != %lld)\n", __FILE__, __LINE__, \
                   #a, #b, check_a_, check_b_);                                          \
            g_check_failed = 1;                                                          \
            return;                                                                      \
        }                                                                                \
    } while (0)

/* Tables defined by each test file. */
extern const test_case_t g_codec_tests[];
extern const test_case_t g_driver_tests[];
extern const test_case_t g_acquisition_tests[];
extern const test_case_t g_cmd_tests[];
extern const test_case_t g_fuzz_tests[];
extern const test_case_t g_store_tests[];
extern const test_case_t g_flash_store_tests[];
extern const test_case_t g_boot_tests[];
extern const test_case_t g_boot_record_tests[];
extern const test_case_t g_watchdog_tests[];

#endif /* CHECK_H */
