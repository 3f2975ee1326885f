/* `wdrctl calibrate --form auto`, measured on the chip being calibrated: every candidate table form
 * is built from the one fit and judged on the same uniform frames as the fit's own model, and the
 * smallest that meets the target is chosen. (It used to choose from fixed figures measured on one
 * 64x48 chip: a chip with more mismatch got a form that missed the target by 2-4x, the matrix of
 * tests/calibration/README.md showed.)
 *
 * A form meets the target at a judged current x when its table's fixed-pattern contrast error
 * there is at most
 *     allowed(x) = max(t.analog_pct, t.floor_ratio * model(x))
 * where model(x) is the fit's own fixed-pattern error on the same frames and pixels (the model in
 * double precision, before any table), the temporal noise taken out of both where a second set of
 * frames measures it. So a form stays within the target, or within 1.2x of what the fit itself
 * reaches where that is more: with the converters on, the quantisation floor as these frames show
 * it (averaged, noisy frames dither the rounding and beat the floor's formula, which would let a
 * form 4x the fit's error pass); on a chip the fit cannot bring within the target. It meets when
 * it does so at every judged current.
 *
 * Typical use:
 *     wdr_form_frames_capture(src, x, n, frames_avg, first_no, &a, &b);
 *     wdr_form_frames f = {a, b, x, n};
 *     wdr_form_table tab = {0};
 *     int k = wdr_form_choose_measured(res, &f, t, sid, op, trials, &nt, &tab, err, sizeof err);
 *     // trials[0..nt-1]: each form tried, smallest first; trials[k] chosen (k < 0: none met)
 */
#ifndef WDR_CAL_FORM_MEASURE_H
#define WDR_CAL_FORM_MEASURE_H
#include "cal_engine.h"
#include "cal_fit.h"
#include <stdint.h>

/* The target: analog_pct (%) and floor_ratio (x the fit's own error): see allowed(x) above. */
typedef struct wdr_form_target {
    double analog_pct, floor_ratio;
} wdr_form_target;
#define WDR_FORM_TARGET_DEFAULT ((wdr_form_target){1.0, 1.2})

/* The forms --form auto tries, smallest table first (bytes per pixel, then the cheaper
 * calibration: compact learns its basis once, shifted twice). */
#define WDR_FORM_CANDIDATES 4

/* One form tried on the chip's frames. */
typedef struct wdr_form_trial {
    int form, n_coeffs;
    double bytes_px;  /* the table's bytes over the chip's pixels (header and basis included) */
    double worst_pct; /* worst table contrast error over the judged currents, % */
    double worst_at;  /* current of worst_pct (A) */
    double excess;    /* worst table error over its allowance (<= 1: meets) */
    double excess_at; /* current of excess (A), with the table error, the fit's and the allowance there */
    double table_pct, model_pct, allowed_pct;
    int meets;
} wdr_form_trial;

#define WDR_FORM_MAX_CURRENTS 64
/* Pixels judged at most (a hashed sample beyond): the sd of 10,000 is known to 0.7 % of itself
 * (a 1 % form to 0.007 %). On sim-vga (307,200 pixels, noise on) the whole calibrate took 84.5 s
 * judging every pixel, 58.2 s with 40,000; 17.3 s with --form compact (no judging) */
#define WDR_FORM_SAMPLE_PIXELS 10000
#define WDR_FORM_FRAME_STRIDE 4096 /* frame numbers per judged current (wdr_form_frames_capture) */

/* The frames the forms are judged on: n uniform frames (frame k at x[k], width * height of the fit
 * each), and a second independent set at the same currents, or NULL. With the second set, the
 * temporal noise both share is measured and taken out of every figure: the forms are judged on
 * their fixed-pattern error, which is all a form can change. */
typedef struct wdr_form_frames {
    const float *frames, *frames_b;
    const double *x;
    int n;
} wdr_form_frames;

/* The chosen form's table, built once (malloc'd; the caller frees table). */
typedef struct wdr_form_table {
    uint8_t *table;
    size_t len;
} wdr_form_table;

/* n frames into *frames (malloc'd, n * width * height, frame k at x[k]), each the average of
 * frames_avg captures numbered first_frame_no + WDR_FORM_FRAME_STRIDE k onwards (frames_avg at
 * most WDR_FORM_FRAME_STRIDE / 2); with frames_b (may be NULL) a second independent set into
 * *frames_b, its captures numbered WDR_FORM_FRAME_STRIDE / 2 on. Both sets at one current before
 * the next: a board lit by hand asks for each current once. @retval WDR_OK, WDR_E_NOMEM, the
 * source's */
int wdr_form_frames_capture(const wdr_cal_source *src, const double *x, int n, int frames_avg, int first_frame_no,
                            float **frames, float **frames_b);

/* Try the candidate forms on res (a spline fit) smallest first, until one meets t on f (at most
 * WDR_FORM_MAX_CURRENTS currents). trials (WDR_FORM_CANDIDATES) gets every form tried, *n_tried of
 * them; table (may be NULL; zeroed by the caller) the chosen form's table or, when none met, the
 * nearest one's (wdr_form_nearest). @return the index of the chosen trial, -1 when none meets
 * (every candidate was tried), -2 on an error (err says which form and why) */
/* When no form meets: the trial nearest its allowance (the smallest worst-over-allowed, the
 * smaller table on a tie), which is kept. basis-8 was kept before, as "the most accurate": on
 * sim-qvga at 2x mismatch, Drago, it is 1.34-1.82x the 12-bit floor where shifted, nearer its
 * allowance on every seed, is 0.90-0.93x (tests/calibration/README.md). */
int wdr_form_nearest(const wdr_form_trial *trials, int n_tried);
int wdr_form_choose_measured(const wdr_cal_result *res, const wdr_form_frames *f, wdr_form_target t, uint32_t sensor_id,
                             int operator_id, wdr_form_trial *trials, int *n_tried, wdr_form_table *table, char *err,
                             int errlen);

/* How fresh frames are taken from a source for the judgement: currents log-spaced over [lo, hi]
 * at (k + WDR_FORM_JUDGING_OFFSET) / currents, each the average of frames_avg captures; with temporal a second set. */
typedef struct wdr_form_judging {
    int currents, frames_avg, temporal, first_frame_no;
} wdr_form_judging;
/* The judged currents of every worst-case figure in this project (bench_target, the study, the
 * calibration matrix): 31 over the range, the first 0.37 of a step in. At the range's very ends
 * every form, basis-8 too, departs from the fit by 2-4x (the pixels' own curves end there). */
#define WDR_FORM_JUDGING_CURRENTS 31
#define WDR_FORM_JUDGING_OFFSET 0.37

/* wdr_form_choose_measured on fresh frames from src (uniform light it sets itself, or a person
 * sets at each current, once), as j says.
 * @return as wdr_form_choose_measured (a failed capture: -2, err names the current) */
int wdr_form_choose_on_source(const wdr_cal_result *res, const wdr_cal_source *src, double lo, double hi,
                              const wdr_form_judging *j, wdr_form_target t, uint32_t sensor_id, int operator_id,
                              wdr_form_trial *trials, int *n_tried, wdr_form_table *table, char *err, int errlen);

#endif
