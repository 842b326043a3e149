/* Live path: reads rows "step x[0] .. x[STAC_N_CH-1]" of one session in time order from
 * stdin, feeds each to stac_push, prints its flags and STAC_N_OUT outputs per row. A row
 * whose step is TARE_STEP calls stac_tare instead (the user zeroes the baseline) and prints
 * nothing. */
#include <stdio.h>

#include "stac_decoder.h"

#define TARE_STEP -100.0

int main(void) {
    stac_assembler a;
    stac_assembler_reset(&a);
    stac_real x[STAC_N_CH];
    stac_real out[STAC_N_OUT];
    for (;;) {
        double step; /* written as a number like the rest of the row */
        if (scanf("%lf", &step) != 1) return 0;
        for (int i = 0; i < STAC_N_CH; ++i) {
            double v;
            if (scanf("%lf", &v) != 1) return 1;
            x[i] = (stac_real)v;
        }
        if (step == TARE_STEP) {
            stac_tare(&a);
            continue;
        }
        for (int i = 0; i < STAC_N_OUT; ++i) out[i] = (stac_real)0;
        int flags = stac_push(&a, (int)step, x, out);
        printf("%d", flags);
        for (int i = 0; i < STAC_N_OUT; ++i) printf(" %.17g", (double)out[i]);
        printf("\n");
    }
}
