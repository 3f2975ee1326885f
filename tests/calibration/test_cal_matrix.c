/* The calibration matrix's CI subset (issue 19; cells of cal_matrix.h, the whole matrix is
 * tests/bench/bench_cal_matrix). On sim-qvga, temporal noise off, defects planted, analog and
 * 12-bit, each cell is held to:
 *   - refused only where expected_refusals says so, for the reason it names (a model that
 *     cannot serve an operator refuses up front), and accepted everywhere else;
 *   - at most MAX_PPM healthy pixels flagged, every planted defect found (both converters);
 *   - 12-bit error at most MAX_FLOOR_RATIO x its floor sqrt(analog^2 + quantisation^2);
 *   - the board's form (spline, auto): analog worst at most MAX_ANALOG_PCT.
 * The limits are the targets; a cell that misses one today is in known_failures with the figure
 * measured, printed as KNOWN on every run. A known failure that now passes fails the test (so the
 * list shrinks as fixes land: remove the entry), and so does any failure not listed. */
#include "cal_matrix.h"
#include "wdr_cal.h"
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define MAX_PPM 10.0
#define MAX_FLOOR_RATIO 1.2
#define MAX_ANALOG_PCT 1.0

enum check { CHECK_ACCEPTED, CHECK_REFUSED, CHECK_PPM, CHECK_FOUND, CHECK_FLOOR, CHECK_ANALOG };
static const char *const check_names[] = {"accepted",      "refused as expected", "ppm flagged",
                                          "defects found", "12-bit / floor",      "analog worst"};

/* The subset: chip runs (every run builds the listed forms; 0 forms: auto only). */
typedef struct run {
    int model;
    const char *op;
    uint64_t seed;
    double mismatch;
    int all_forms;
} run;

static const run subset[] = {
    /* the board's default: spline, every operator, three seeds at 1x; Reinhard at 2x */
    {WDR_MODEL_SPLINE, "reinhard", 1, 1, 0},
    {WDR_MODEL_SPLINE, "reinhard", 2, 1, 0},
    {WDR_MODEL_SPLINE, "reinhard", 3, 1, 0},
    {WDR_MODEL_SPLINE, "reinhard", 1, 2, 0},
    {WDR_MODEL_SPLINE, "drago", 1, 1, 0},
    {WDR_MODEL_SPLINE, "tumblin_rushmeier", 2, 1, 0},
    {WDR_MODEL_SPLINE, "schlick", 3, 1, 0},
    /* the paper's models where the independent check found them concealing or refusing */
    {WDR_MODEL_COMPLEX4, "reinhard", 1, 1, 0},
    {WDR_MODEL_COMPLEX4, "reinhard", 2, 1, 0},
    {WDR_MODEL_COMPLEX4, "drago", 1, 1, 0},
    {WDR_MODEL_COMPLEX4, "schlick", 2, 1, 0},
    {WDR_MODEL_COMPLEX4, "exponential", 1, 1, 0},
    {WDR_MODEL_SIMPLE3, "reinhard", 2, 1, 0},
    {WDR_MODEL_SIMPLE3, "drago", 1, 1, 0},
    {WDR_MODEL_SIMPLE3, "tumblin_rushmeier", 3, 1, 0},
    {WDR_MODEL_SIMPLE3, "logarithmic", 1, 2, 0},
    {WDR_MODEL_LSQ, "reinhard", 3, 1, 0},
    {WDR_MODEL_POLYMAP, "drago", 2, 1, 0},
};

/* Where a model cannot serve an operator: refused up front (seed 0: every seed), the reason
 * containing `because`. */
typedef struct refusal {
    int model;
    const char *op;
    const char *because;
} refusal;

static const refusal expected_refusals[] = {
    /* from the design, before any frame, or after the probe (host/cal/metrics/cal_select.c) */
    {WDR_MODEL_SIMPLE3, "drago", "cannot serve this response"},
    {WDR_MODEL_SIMPLE3, "tumblin_rushmeier", "cannot serve this response"},
    {WDR_MODEL_SIMPLE3, "logarithmic", "cannot serve this response"},
    {WDR_MODEL_COMPLEX4, "tumblin_rushmeier", "cannot serve this response"},
    {WDR_MODEL_COMPLEX4, "logarithmic", "cannot serve this response"},
    {WDR_MODEL_COMPLEX4, "drago", "cannot serve this response"},
};

/* Open failures, measured on this tree (the figure is what the check saw when it was listed). */
typedef struct known {
    int model;
    const char *op;
    uint64_t seed;
    double mismatch;
    int side; /* 0 analog, 1 12-bit, -1 both or not per side */
    enum check check;
    double figure;
    const char *note;
} known;

static const known known_failures[] = {
    /* (2026-12-07: spline reinhard seed 1 1x analog, compact at 1.268 %, holds at 0.544 % since the
     * compact table takes conditioned functions where they encode better, cal_basis_condition.c;
     * with the learnt functions alone it fails here again as a miss not listed) */
    /* item 3 (the margin sized from the chip) brought the 2x cells' flags to 0 (were 4,534 and
     * 2,345 ppm, "flat response", with the fixed 60 mV); measured auto gives the 2x chip poly-5 */
    /* item 5: one planted defect not flagged on this chip */
    {WDR_MODEL_SPLINE, "schlick", 3, 1, 0, CHECK_FOUND, 1, "11 of 12 found"},
    {WDR_MODEL_SPLINE, "schlick", 3, 1, 1, CHECK_FOUND, 1, "11 of 12 found"},
    /* item 2: complex4 now flags no healthy pixel (its least squares held falling), but its
     * 12-bit figure with every pixel fitted is above 1.2x the floor; exponential, served now,
     * is far above it at the dark end */
    {WDR_MODEL_COMPLEX4, "reinhard", 1, 1, 1, CHECK_FLOOR, 1.308, "poly-5 of the held fit, 9.44e-12 A"},
    {WDR_MODEL_COMPLEX4, "reinhard", 2, 1, 1, CHECK_FLOOR, 1.314, "poly-5 of the held fit, 9.44e-12 A"},
    {WDR_MODEL_COMPLEX4, "exponential", 1, 1, 1, CHECK_FLOOR, 3.83, "the model itself, 1.2e-12 A"},
    /* lsq's poly-5 table at 12 bits (dark end, 2.3e-11 A) */
    {WDR_MODEL_LSQ, "reinhard", 3, 1, 1, CHECK_FLOOR, 4.182, "poly-5 table of the lsq model"},
    {0, NULL, 0, 0, 0, 0, 0, NULL}, /* end */
};

static int failures, knowns, fixed;

static const known *find_known(const cm_cell *c, int side, enum check k)
{
    for (const known *e = known_failures; e->op; e++) {
        if (e->model == c->model && !strcmp(e->op, c->op) && e->seed == c->seed && e->mismatch == c->mismatch &&
            (e->side == side || e->side == -1) && e->check == k)
            return e;
    }
    return NULL;
}

static const refusal *find_refusal(const cm_cell *c)
{
    for (size_t i = 0; i < sizeof expected_refusals / sizeof expected_refusals[0]; i++)
        if (expected_refusals[i].model == c->model && !strcmp(expected_refusals[i].op, c->op))
            return &expected_refusals[i];
    return NULL;
}

/* A listed failure may not grow past this factor of its listed figure: a known miss that gets
 * much worse is a new fault (a 20 mV margin took a listed 4,534 ppm to 186,106 unseen). */
#define KNOWN_WORSE 1.25

/* One check of one cell: ok, a listed failure (KNOWN), a listed failure that now holds (FIXED:
 * fails, the list must shrink), a listed failure grown past KNOWN_WORSE (fails), or a new failure. */
static void judge(const cm_cell *c, int side, enum check k, int ok, double figure, const char *limit)
{
    const known *e = find_known(c, side, k);
    const char *sn = side == 0 ? "analog" : side == 1 ? "12-bit" : "both";
    if (ok && !e)
        return;
    printf("  %s %s seed %llu %gx %s: %s %.4g (limit %s)", cm_model_name(c->model), c->op, (unsigned long long)c->seed,
           c->mismatch, sn, check_names[k], figure, limit);
    if (ok) {
        fixed++, failures++;
        printf(" FIXED: now holds; remove it from known_failures (listed at %.4g)\n", e->figure);
    } else if (e && figure > KNOWN_WORSE * e->figure + 1e-9) { /* listed, but worse than listed */
        failures++;
        printf(" FAIL: listed at %.4g, now more than %.3gx that (%s)\n", e->figure, KNOWN_WORSE, e->note);
    } else if (e) {
        knowns++;
        printf(" KNOWN (listed at %.4g: %s)\n", e->figure, e->note);
    } else {
        failures++;
        printf(" FAIL\n");
    }
}

static void check_cell(const cm_cell *c)
{
    const refusal *r = find_refusal(c);
    for (int v = 0; v < 2; v++) {
        const cm_side *s = &c->side[v];
        if (r) {
            int ok = s->refused && strstr(s->reason, r->because);
            if (!ok)
                printf("  expected refusal (%s): %s\n", r->because, s->refused ? s->reason : "accepted");
            judge(c, v, CHECK_REFUSED, ok, s->refused, "refused");
            continue;
        }
        if (s->refused)
            printf("  refused: %s\n", s->reason);
        judge(c, v, CHECK_ACCEPTED, !s->refused, !s->refused, "accepted");
        if (s->refused)
            continue;
        judge(c, v, CHECK_PPM, cm_ppm(s) <= MAX_PPM, cm_ppm(s), "10 ppm");
        judge(c, v, CHECK_FOUND, s->planted_found == s->planted, (double)(s->planted - s->planted_found),
              "0 planted missed");
        if (v == 0 && c->model == WDR_MODEL_SPLINE && c->asked_auto)
            judge(c, v, CHECK_ANALOG, s->worst_pct <= MAX_ANALOG_PCT, s->worst_pct, "1 %");
    }
    if (!r && !c->side[0].refused && !c->side[1].refused)
        judge(c, 1, CHECK_FLOOR, c->floor_ratio <= MAX_FLOOR_RATIO, c->floor_ratio, "1.2x");
}

int main(int argc, char **argv)
{
    cm_setup s = {.plant_defects = 1};
    const char *only = NULL; /* "MODEL:OP": only the runs whose model and operator match */
    int only_seed = 0;       /* and, if not 0, only that chip seed (at every mismatch) */
    for (int i = 1; i < argc; i++)
        if (!strcmp(argv[i], "--only") && i + 1 < argc)
            only = argv[++i];
        else if (!strcmp(argv[i], "--seed") && i + 1 < argc && sscanf(argv[i + 1], "%d", &only_seed) == 1)
            i++;
        else if (sscanf(argv[i], "%dx%d", &s.width, &s.height) != 2)
            return fprintf(stderr, "usage: test_cal_matrix [WxH] [--only MODEL:OP] [--seed N]\n"), 64;
    cm_print_header(stdout);
    for (size_t i = 0; i < sizeof subset / sizeof subset[0]; i++) {
        const run *r = &subset[i];
        char name[64];
        snprintf(name, sizeof name, "%s:%s", cm_model_name(r->model), r->op);
        if ((only && strcmp(only, name)) || (only_seed > 0 && r->seed != (uint64_t)only_seed))
            continue;
        int forms[CM_MAX_FORMS] = {CM_FORM_AUTO}, n[CM_MAX_FORMS] = {0}, nf = 1;
        if (r->all_forms)
            nf = cm_model_forms(r->model, forms, n);
        cm_cell cells[CM_MAX_FORMS];
        if (cm_run_chip(&s, r->model, r->op, r->seed, r->mismatch, forms, n, nf, cells))
            return 1;
        for (int f = 0; f < nf; f++) {
            cm_print_row(stdout, &cells[f]);
            check_cell(&cells[f]);
        }
        fflush(stdout);
    }
    printf("test_cal_matrix: %d failures (%d of them known failures that now hold), %d known failures open\n", failures,
           fixed, knowns);
    return failures ? 1 : 0;
}
