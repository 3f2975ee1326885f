/* `wdrctl calibrate --form auto`, measured on the chip (host/cal/metrics/cal_form_measure.h),
 * checked independently: on bench_target's analog chips (64x48; tests/bench/bench_target_study.h)
 * the chooser picks a form from fresh frames, then every candidate's table is judged by the other
 * metric path (wdr_cal_evaluate: sd of (x_hat - x) / x through the kernel, at the same 31
 * currents), against the 1 % target:
 *   - the form chosen meets it, unless none met (the nearest kept);
 *   - every smaller form passed over misses it: auto took the smallest that holds;
 *   - the expected choices: compact for Reinhard, shifted for Drago (seed 11, 1x).
 * The two paths differ in their metric (ln against linear, and which pixels each leaves out): by up
 * to 0.52 % on a 4.7 % form, by at most 0.017 % near the 1 % target (Tumblin-Rushmeier shifted,
 * 0.997 against 0.980 %). TOLERANCE allows 0.02 % either way there.
 *
 *   test_cal_form_auto [memory] [onechip]
 * memory (the sanitizers' run): the first two chips only (every code path; Release holds all).
 * onechip plants the old fault (a form table measured on one chip): every chip of an operator gets
 * the form auto chose on that operator's first chip. At 2x mismatch compact misses 1 % on Reinhard
 * (2-4 %, tests/calibration/README.md) and the test fails. */
#include "../bench/bench_target_study.h"
#include "cal_form_measure.h"
#include "wdr_lut.h"
#include <string.h>

#define TOLERANCE 0.02 /* % */

typedef struct chip_run {
    const char *op;
    uint32_t seed;
    double mismatch;
    int expect; /* the form auto must choose; 0: any that passes the checks */
} chip_run;

static const chip_run runs[] = {
    {"reinhard", 11, 1, WDR_FORM_COMPACT}, {"reinhard", 11, 2, 0},
    {"drago", 11, 1, WDR_FORM_SHIFTED},    {"drago", 7, 2, 0},
    {"tumblin_rushmeier", 11, 1, 0},       {"schlick", 3, 1, 0},
};

static const char *form_name(int form)
{
    switch (form) {
    case WDR_FORM_COMPACT: return "compact";
    case WDR_FORM_SHIFTED: return "shifted";
    case WDR_FORM_POLY: return "poly-5";
    case WDR_FORM_BASIS: return "basis-8";
    default: return "?";
    }
}

/* The chooser's trials, each re-judged by study_worst. @return failures */
static int check(study_chip *c, const wdr_cal_result *res, const wdr_form_trial *tr, int nt, int given, int none_met)
{
    int failed = 0;
    for (int k = 0; k < nt; k++) {
        double w = study_worst(c, res, tr[k].form, tr[k].n_coeffs);
        int is_given = tr[k].form == given, passed_over = k < nt - 1 || none_met;
        const char *verdict = "";
        if (is_given && !none_met && !(w <= 1 + TOLERANCE))
            verdict = " FAIL: given, but it misses 1 %", failed++;
        else if (!is_given && passed_over && !(w > 1 - TOLERANCE))
            verdict = " FAIL: passed over, but it meets 1 %", failed++;
        printf("  %-8s auto measured %.3f %% (%.2fx its allowance); the other path %.3f %%%s%s\n",
               form_name(tr[k].form), tr[k].worst_pct, tr[k].excess, w, is_given ? " <- given" : "", verdict);
    }
    return failed;
}

int main(int argc, char **argv)
{
    int onechip = 0, memory = 0, failed = 0;
    for (int i = 1; i < argc; i++)
        if (!strcmp(argv[i], "onechip"))
            onechip = 1;
        else if (!strcmp(argv[i], "memory"))
            memory = 1;
        else
            return fprintf(stderr, "usage: test_cal_form_auto [memory] [onechip]\n"), 64;
    const char *first_op = "";
    int first_choice = 0;
    for (size_t i = 0; i < (memory ? 2 : sizeof runs / sizeof runs[0]); i++) {
        const chip_run *r = &runs[i];
        study_chip c;
        wdr_cal_result res;
        wdr_form_trial tr[WDR_FORM_CANDIDATES];
        char err[512];
        int nt;
        if (study_open_chip_mismatch(&c, r->op, STUDY_W, STUDY_H, r->seed, r->mismatch) ||
            study_fit(&c, WDR_MODEL_SPLINE, 19, &res))
            return 1;
        wdr_form_judging j = {WDR_FORM_JUDGING_CURRENTS, 1, 0, 7000000};
        int k = wdr_form_choose_on_source(&res, &c.src, c.lo, c.hi, &j, WDR_FORM_TARGET_DEFAULT, 1, 1, tr, &nt, NULL,
                                          err, sizeof err);
        if (k == -2)
            return printf("%s: form auto: %s FAIL\n", r->op, err), 1;
        int chose = tr[k < 0 ? wdr_form_nearest(tr, nt) : k].form;
        if (strcmp(first_op, r->op))
            first_op = r->op, first_choice = chose;
        int given = onechip ? first_choice : chose;
        printf("%s seed %u %gx: auto chose %s%s%s\n", r->op, r->seed, r->mismatch, form_name(chose),
               k < 0 ? " (none met: the nearest kept)" : "", onechip ? "; planted: given the first chip's choice" : "");
        failed += check(&c, &res, tr, nt, given, k < 0);
        if (onechip && given != chose) { /* the given form's own figure, when auto did not try it */
            double w = study_worst(&c, &res, given, given == WDR_FORM_POLY ? 5 : given == WDR_FORM_BASIS ? 8 : 4);
            int ok = w <= 1 + TOLERANCE;
            printf("  given %s: the other path %.3f %% %s\n", form_name(given), w, ok ? "ok" : "FAIL: misses 1 %");
            failed += !ok;
        }
        if (r->expect && chose != r->expect)
            printf("  expected %s FAIL\n", form_name(r->expect)), failed++;
        wdr_cal_result_free(&res);
        study_close(&c);
        fflush(stdout);
    }
    printf("test_cal_form_auto: %d failures\n", failed);
    return failed ? 1 : 0;
}
