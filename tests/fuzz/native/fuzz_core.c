/* libFuzzer harness over the firmware core's receive and command path, on the fake board of
 * the C unit tests: the input arrives on the UART in chunks, the superloop runs between
 * chunks. Checked per input (ASan and UBSan watch memory and arithmetic):
 *   - every frame the core sends is well formed (COBS, CRC, header);
 *   - afterwards a delimiter and GET_INFO are answered with INFO (the core recovers from any
 *     byte sequence, including half frames and oversize runs).
 * Built from tools/firmware/build.toml target "fuzz-core" with clang -fsanitize=fuzzer. */
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>

#include "fake_board.h"
#include "stac_app.h"

#define CHUNK 512u
#define MAX_FRAMES 256

static fake_board_t g_board;
static stac_app_t g_app;
static fake_frame_t g_frames[MAX_FRAMES];

static void run_passes(int passes) {
    for (int p = 0; p < passes; p++) {
        stac_app_step(&g_app, g_board.now);
        g_board.now += 250u;
    }
}

static int check_output(void) {
    const int n = fake_frames(&g_board, g_frames, MAX_FRAMES);
    if (n < 0) {
        abort(); /* the core sent a malformed frame */
    }
    return n;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    fake_init(&g_board);
    fake_boot(&g_board, &g_app);
    fake_clear_tx(&g_board);
    size_t pos = 0;
    while (pos < size) {
        size_t n = size - pos;
        if (n > CHUNK) {
            n = CHUNK;
        }
        fake_send_raw(&g_board, data + pos, n);
        pos += n;
        run_passes(4);
        (void)check_output();
        fake_clear_tx(&g_board);
    }
    const uint8_t delimiter = 0u;
    fake_send_raw(&g_board, &delimiter, 1u);
    fake_send(&g_board, STAC_MSG_GET_INFO, 77u, NULL, 0u);
    run_passes(2);
    const int n = check_output();
    if (fake_count(g_frames, n, STAC_MSG_INFO) < 1) {
        abort(); /* GET_INFO after the input was not answered: the core did not recover */
    }
    return 0;
}
