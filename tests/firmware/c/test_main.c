/* Runs the C unit tests: no argument runs all, `--list` names them, NAME runs one. */
#include <string.h>

#include "check.h"

int g_check_failed;

static const test_case_t *const k_tables[] = {
    g_codec_tests, g_driver_tests, g_sched_tests, g_cmd_tests, g_fuzz_tests,
};

int main(int argc, char **argv) {
    const char *only = argc > 1 ? argv[1] : NULL;
    const int list = only != NULL && strcmp(only, "--list") == 0;
    int ran = 0;
    int failed = 0;
    for (size_t t = 0; t < sizeof k_tables / sizeof k_tables[0]; t++) {
        for (const test_case_t *c = k_tables[t]; c->name != NULL; c++) {
            if (list) {
                printf("%s\n", c->name);
                continue;
            }
            if (only != NULL && strcmp(only, c->name) != 0) {
                continue;
            }
            g_check_failed = 0;
            c->fn();
            ran++;
            failed += g_check_failed;
            printf("%s %s\n", g_check_failed ? "FAIL" : "PASS", c->name);
        }
    }
    if (list) {
        return 0;
    }
    if (ran == 0) {
        printf("no test named %s\n", only != NULL ? only : "(any)");
        return 2;
    }
    printf("%d tests, %d failed\n", ran, failed);
    return failed != 0;
}
