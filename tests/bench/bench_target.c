#include "bench_target_study.h"
int main(void)
{
    for (int o = 0; o < STUDY_OPS; o++) {
        study_chip c;
        wdr_cal_result res;
        if (study_open(&c, study_ops[o]) || study_fit(&c, WDR_MODEL_SPLINE, 19, &res))
            return 1;
        printf("%-18s basis8 %.3f basis4 %.3f compact %.3f poly5 %.3f\n", study_ops[o],
               study_worst(&c, &res, WDR_FORM_BASIS, 8), study_worst(&c, &res, WDR_FORM_BASIS, 4),
               study_worst(&c, &res, WDR_FORM_COMPACT, 4), study_worst(&c, &res, WDR_FORM_POLY, 5));
        fflush(stdout);
        wdr_cal_result_free(&res);
        study_close(&c);
    }
}
