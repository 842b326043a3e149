/* Runs the C unit tests: no argument runs all, `--list` names them, NAME runs one. */
#include "check.h"

static const test_case_t *const k_tables[] = {
    g_codec_tests, g_driver_tests, g_acquisition_tests, g_cmd_tests, g_fuzz_tests, g_store_tests,
    g_flash_store_tests, g_boot_tests, g_boot_record_tests, g_watchdog_tests,
};

int main(int argc, char **argv) {
    return check_main(k_tables, sizeof k_tables / sizeof k_tables[0], argc > 1 ? argv[1] : NULL);
}
