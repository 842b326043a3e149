/* Model check on the host: `model_check IMAGE INPUT OUTPUT` (model_check.h). No timer: the
 * native build checks numbers, QEMU measures cost. */
#include <stdio.h>
#include <stdlib.h>

#include "model_check.h"

#define MAX_IMAGE (1u << 20)

static _Alignas(8) uint8_t g_image[MAX_IMAGE];
static FILE *g_in, *g_out;

uint32_t mc_read(uint8_t *buf, uint32_t n) { return (uint32_t)fread(buf, 1, n, g_in); }

void mc_write(const uint8_t *buf, uint32_t n) {
    if (fwrite(buf, 1, n, g_out) != n) exit(4);
}

uint32_t mc_ticks(void) { return 0u; }

uint32_t mc_calibrate(uint32_t iterations) {
    (void)iterations;
    return 0u;
}

int main(int argc, char **argv) {
    if (argc != 4) {
        fprintf(stderr, "usage: model_check IMAGE INPUT OUTPUT\n");
        return 1;
    }
    FILE *f = fopen(argv[1], "rb");
    if (f == NULL) return 1;
    const size_t size = fread(g_image, 1, MAX_IMAGE, f);
    fclose(f);
    g_in = fopen(argv[2], "rb");
    g_out = fopen(argv[3], "wb");
    if (g_in == NULL || g_out == NULL) return 1;
    const int rc = mc_run(g_image, (uint32_t)size);
    fclose(g_in);
    fclose(g_out);
    if (rc == 2) fprintf(stderr, "stac_model_open: the image is invalid\n");
    return rc;
}
