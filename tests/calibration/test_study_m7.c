/* The study's M7 instruction counts (host/study/study_m7.c) are bench_target's, within 0.5 %:
 *   test_study_m7 COUNTS   (COUNTS from bench_target --counts; .ci/test runs both)
 * Planted in the commit that added it: a count edited by 1 % in COUNTS fails. */
#include "study.h"
#include <math.h>
#include <stdio.h>

int main(int argc, char **argv)
{
    FILE *f = argc > 1 ? fopen(argv[1], "r") : NULL;
    if (!f)
        return fprintf(stderr, "test_study_m7: give bench_target's --counts file\n"), 2;
    int form, n, seen = 0, failed = 0;
    double corr, row;
    while (fscanf(f, "%d %d %lf %lf", &form, &n, &corr, &row) == 4) {
        double c, r;
        study_m7_for(form, n, &c, &r);
        int ok = fabs(c - corr) <= 0.005 * corr && fabs(r - row) <= 0.005 * row;
        printf("form %d (%d coefficients): bench_target %.2f / %.2f, study %.2f / %.2f %s\n", form, n, corr, row, c, r,
               ok ? "ok" : "FAIL (> 0.5 %)");
        failed += !ok;
        seen++;
    }
    fclose(f);
    return failed || seen == 0 ? 1 : 0;
}
