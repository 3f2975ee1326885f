/* The SHIFTED form (format 1.3: COMPACT's 9 bytes a pixel, four shared functions, plus a code
 * shift per pixel) holds every operator to 1 % worst contrast error, analog case, through the
 * kernel's fixed-point arithmetic: the 64x48 chip of bench_target, seed 11, judged at 31 currents.
 * `test_cal_shifted compact` runs the same judgement on the COMPACT form (the old four functions,
 * no shift), which fails on Tumblin-Rushmeier (2.14 %) and Drago (1.31 %): the plant this test
 * was seen failing with. `--only OP` judges one operator (the sanitizers' run: the same code for all
 * seven, a seventh of the time). */
#include "../bench/bench_target_study.h"
#include <string.h>

#define LIMIT_PCT 1.0

int main(int argc, char **argv)
{
    int form = WDR_FORM_SHIFTED, failed = 0, judged = 0;
    const char *only = NULL;
    for (int a = 1; a < argc; a++) {
        if (!strcmp(argv[a], "compact"))
            form = WDR_FORM_COMPACT;
        else if (!strcmp(argv[a], "--only") && a + 1 < argc)
            only = argv[++a];
        else {
            fprintf(stderr, "test_cal_shifted: unknown argument '%s' (compact, --only OP)\n", argv[a]);
            return 64;
        }
    }
    for (int o = 0; o < STUDY_OPS; o++) {
        if (only && strcmp(only, study_ops[o]))
            continue;
        judged++;
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
    if (!judged)
        fprintf(stderr, "test_cal_shifted: --only '%s' names no operator of the study\n", only);
    return failed || !judged ? 1 : 0;
}
