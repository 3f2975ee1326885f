/* The calibration matrix (issue 19): every model x operator x table form x chip seed x mismatch
 * x converters on a simulated chip (sim-qvga unless told), each cell computed with the library's
 * own calibration (host/cal: probe grid, informative range, current selection, fit, table) and
 * its metrics (cal_metrics.h), as `wdrctl calibrate` and tests/bench/bench_floor.c do.
 *
 * One "chip run" is (model, operator, seed, mismatch): the same chip twice, analog (ADC and DAC
 * quantisation off) and 12-bit (both on), temporal noise off (the condition the quantisation
 * floor is defined in), defects planted (dead, stuck, hot, saturated). It fills one cell per
 * table form. Shared by tests/calibration/test_cal_matrix.c (the CI subset, limits held) and
 * tests/bench/bench_cal_matrix.c (the whole matrix, a table). */
#ifndef CAL_MATRIX_H
#define CAL_MATRIX_H
#include <stdint.h>
#include <stdio.h>

#define CM_FORM_AUTO (-1) /* `wdrctl calibrate --form auto`'s choice for the model and operator */
#define CM_MAX_FORMS 6
#define CM_N_TEST 31      /* judged currents, log-spaced over the analog chip's informative range */
#define CM_DEFECT_PPM 100 /* of each kind, plus one of each at the corners */
#define CM_REASON 200

typedef struct cm_setup {
    const char *board; /* board name (WDR_BOARDS_DIR) or file; NULL: sim-qvga */
    int width, height; /* 0: the board's */
    int plant_defects; /* 1: dead, stuck, hot, saturated planted (CM_DEFECT_PPM each) */
    int analog_only;   /* 1: the 12-bit chip is not run (side[1] refused, no floor ratio, no auto): half the time */
} cm_setup;

/* One converter condition of one cell. */
typedef struct cm_side {
    int refused; /* selection, fit or table refused (reason says where and why) */
    char reason[CM_REASON];
    long healthy, healthy_flagged; /* pixels without a planted defect, and of them flagged (table flags) */
    long planted, planted_found;
    double worst_pct, worst_at; /* worst table contrast error over the judged currents (flagged left out) */
    double lo, hi;              /* judged range (the analog chip's informative range) */
} cm_side;

typedef struct cm_cell {
    int model; /* enum wdr_cal_model_id */
    const char *op;
    int form, n_coeffs; /* the form built (for CM_FORM_AUTO: the one auto chose) */
    int asked_auto;     /* the cell is `auto` */
    uint64_t seed;
    double mismatch;    /* every mismatch figure of the board times this */
    cm_side side[2];    /* 0 analog, 1 12-bit */
    double floor_ratio; /* worst over currents of 12-bit error / sqrt(analog^2 + quantisation floor^2) */
    double ratio_at, ratio_err, ratio_floor; /* where, the 12-bit error there and the floor there (%) */
    double model_ratio;                      /* the same through the model's own inverse in double (no table): above
                                                1.2x the cause is the model and its levels, not the table form */
    double seconds;                          /* this chip run's time, shared by its cells */
} cm_cell;

/* The forms a model offers `wdrctl calibrate` (auto last): simple3 moebius, poly-5; complex4, lsq,
 * polymap poly-5; spline basis-8, poly-5, compact, shifted. @return the count written to forms */
int cm_model_forms(int model, int *forms, int *n_coeffs);

/* Run model under op on chip seed at mismatch x the board's figures for the nf forms of
 * forms/n_coeffs (CM_FORM_AUTO allowed); cells gets nf cells. @retval 0, or 1 when the chip
 * itself could not be set up (printed) */
int cm_run_chip(const cm_setup *s, int model, const char *op, uint64_t seed, double mismatch, const int *forms,
                const int *n_coeffs, int nf, cm_cell *cells);

const char *cm_model_name(int model);
int cm_model_from_name(const char *name); /* -1 when unknown */
const char *cm_form_name(int form, int n_coeffs, char *buf, int cap);
int cm_form_from_name(const char *name, int *form, int *n_coeffs); /* 0 ok, -1 unknown */

/* Healthy pixels flagged, in ppm of the healthy pixels. */
double cm_ppm(const cm_side *s);

/* One markdown table row per cell; the header first. */
void cm_print_header(FILE *f);
void cm_print_row(FILE *f, const cm_cell *c);

#endif
