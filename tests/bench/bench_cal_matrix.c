/* The whole calibration matrix (issue 19, tests/calibration/cal_matrix.h): every model x operator
 * x table form (each model's forms and auto) x chip seed x mismatch, analog and 12-bit, on
 * sim-qvga, as one markdown table (tests/calibration/README.md holds a run's). Temporal noise off
 * (the quantisation floor's condition), defects planted (dead, stuck, hot, saturated at 100 ppm
 * each and one of each at the corners; "ppm flagged" counts healthy pixels only).
 *
 *   bench_cal_matrix [--models spline,simple3,..] [--ops reinhard,drago,..] [--forms basis-8,auto,..]
 *                    [--seeds 1,2,3] [--mismatch 1,2] [--board NAME] [--size WxH] [--no-defects]
 *                    [--no-header] [--quick]
 * (--quick: spline, Reinhard, auto, seed 1, 1x, 64x48: proves the program runs.) Every chip run
 * is independent: run them two at a time with GNU parallel, e.g.
 *   parallel -j2 -k bench_cal_matrix --no-header --models {1} --ops {2} ::: simple3 complex4 lsq \
 *       polymap spline ::: reinhard reinhard_white schlick tumblin_rushmeier drago exponential logarithmic */
#include "bench_util.h"
#include "cal_matrix.h"
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define MAX_LIST 16

static const char *const all_ops = "reinhard,reinhard_white,schlick,tumblin_rushmeier,drago,exponential,logarithmic";

static int split(const char *text, char out[][32], int max)
{
    int n = 0;
    const char *p = text;
    while (*p && n < max) {
        size_t len = strcspn(p, ",");
        if (len && len < 32)
            memcpy(out[n], p, len), out[n++][len] = 0;
        p += len + (p[len] == ',');
    }
    return n;
}

static int usage(const char *arg)
{
    fprintf(stderr, "bench_cal_matrix: bad argument '%s' (see the comment at the top of bench_cal_matrix.c)\n", arg);
    return 64;
}

int main(int argc, char **argv)
{
    const char *models = "simple3,complex4,lsq,polymap,spline", *ops = all_ops, *forms = NULL, *seeds = "1,2,3",
               *mism = "1,2";
    cm_setup s = {.plant_defects = 1};
    int header = 1;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : NULL;
        if (!strcmp(a, "--quick"))
            models = "spline", ops = "reinhard", forms = "auto", seeds = "1", mism = "1", s.width = 64, s.height = 48;
        else if (!strcmp(a, "--no-header"))
            header = 0;
        else if (!strcmp(a, "--no-defects"))
            s.plant_defects = 0;
        else if (!v)
            return usage(a);
        else if (!strcmp(a, "--models"))
            models = v, i++;
        else if (!strcmp(a, "--ops"))
            ops = v, i++;
        else if (!strcmp(a, "--forms"))
            forms = v, i++;
        else if (!strcmp(a, "--seeds"))
            seeds = v, i++;
        else if (!strcmp(a, "--mismatch"))
            mism = v, i++;
        else if (!strcmp(a, "--board"))
            s.board = v, i++;
        else if (!strcmp(a, "--size") && sscanf(v, "%dx%d", &s.width, &s.height) == 2 && s.width > 0 && s.height > 0)
            i++;
        else
            return usage(a);
    }
    char ml[MAX_LIST][32], ol[MAX_LIST][32], fl[MAX_LIST][32], sl[MAX_LIST][32], mml[MAX_LIST][32];
    int nm = split(models, ml, MAX_LIST), no = split(ops, ol, MAX_LIST), ns = split(seeds, sl, MAX_LIST),
        nmm = split(mism, mml, MAX_LIST), nfl = forms ? split(forms, fl, MAX_LIST) : 0;
    if (header) {
        printf("bench_cal_matrix: board %s%s, defects %s, temporal noise off, %d judged currents, auto judged on "
               "each chip's 12-bit frames (the nearest kept when none meets)\n",
               s.board ? s.board : "sim-qvga", s.width ? " (resized)" : "", s.plant_defects ? "planted" : "none",
               CM_N_TEST);
        cm_print_header(stdout);
    }
    double t0 = now_s();
    int chips = 0;
    for (int m = 0; m < nm; m++) {
        int model = cm_model_from_name(ml[m]), f_id[CM_MAX_FORMS], f_n[CM_MAX_FORMS], nf = 0;
        if (model < 0)
            return usage(ml[m]);
        if (!forms)
            nf = cm_model_forms(model, f_id, f_n);
        for (int k = 0; k < nfl && nf < CM_MAX_FORMS; k++, nf++)
            if (cm_form_from_name(fl[k], &f_id[nf], &f_n[nf]))
                return usage(fl[k]);
        for (int o = 0; o < no; o++)
            for (int sd = 0; sd < ns; sd++)
                for (int k = 0; k < nmm; k++) {
                    cm_cell cells[CM_MAX_FORMS];
                    double t = now_s();
                    if (cm_run_chip(&s, model, ol[o], strtoull(sl[sd], NULL, 10), atof(mml[k]), f_id, f_n, nf, cells))
                        return 1;
                    for (int f = 0; f < nf; f++)
                        cm_print_row(stdout, &cells[f]);
                    fflush(stdout);
                    fprintf(stderr, "bench_cal_matrix: %s %s seed %s %sx: %.1f s\n", ml[m], ol[o], sl[sd], mml[k],
                            now_s() - t);
                    chips++;
                }
    }
    fprintf(stderr, "bench_cal_matrix: %d chip runs in %.1f s\n", chips, now_s() - t0);
    return 0;
}
