/* The SHIFTED form (format 1.3: COMPACT's 9 bytes a pixel, four shared functions, plus a code
 * shift per pixel) holds every operator to 1 % worst contrast error, analog case, through the
 * kernel's fixed-point arithmetic: the 64x48 chip of bench_target, seed 11, judged at 31 currents.
 * `test_cal_shifted compact` runs the same judgement on the COMPACT form (the old four functions,
 * no shift), which fails on Tumblin-Rushmeier (2.14 %) and Drago (1.31 %): the plant this test
 * was seen failing with. */
#include "../bench/bench_target_study.h"
#include <string.h>

#define LIMIT_PCT 1.0

int main(int argc, char **argv)
{
    int form = argc > 1 && !strcmp(argv[1], "compact") ? WDR_FORM_COMPACT : WDR_FORM_SHIFTED, failed = 0;
    for (int o = 0; o < STUDY_OPS; o++) {
        study_chip c;
        wdr_cal_result sp;
        if (study_open(&c, study_ops[o]) || study_fit(&c, WDR_MODEL_SPLINE, 19, &sp))
            return 1;
        double w = study_worst(&c, &sp, form, 4);
        int ok = w <= LIMIT_PCT; /* NaN (no table) fails */
        printf("%-18s %s worst %.3f %% %s\n", study_ops[o], form == WDR_FORM_SHIFTED ? "shifted" : "compact", w,
               ok ? "ok" : "FAIL (limit 1 %)");
        fflush(stdout);
        failed += !ok;
        wdr_cal_result_free(&sp);
        study_close(&c);
    }
    return failed ? 1 : 0;
}
