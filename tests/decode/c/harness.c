/* Reads rows of STAC_N_IN numbers from stdin, prints flags and STAC_N_OUT outputs per row. */
#include <stdio.h>

#include "stac_decoder.h"

int main(void) {
    stac_real u[STAC_N_IN];
    stac_real out[STAC_N_OUT];
    for (;;) {
        for (int i = 0; i < STAC_N_IN; ++i) {
            double v;
            if (scanf("%lf", &v) != 1) return 0;
            u[i] = (stac_real)v;
        }
        for (int i = 0; i < STAC_N_OUT; ++i) out[i] = (stac_real)0;
        int flags = stac_decode(u, out);
        printf("%d", flags);
        for (int i = 0; i < STAC_N_OUT; ++i) printf(" %.17g", (double)out[i]);
        printf("\n");
    }
}
