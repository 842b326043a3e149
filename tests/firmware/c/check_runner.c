/* The runner every C test program shares: no argument runs all tests, `--list` names them,
 * NAME runs that one (pytest runs each separately). Exit 0 all passed, 1 a test failed,
 * 2 no test had that name. */
#include <string.h>

#include "check.h"

int g_check_failed;

int check_main(const test_case_t *const *tables, size_t n_tables, const char *only) {
    const int list = only != NULL && strcmp(only, "--list") == 0;
    int ran = 0;
    int failed = 0;
    for (size_t t = 0; t < n_tables; t++) {
        for (const test_case_t *c = tables[t]; c->name != NULL; c++) {
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
