/* `wdrctl calibrate --form auto`: the smallest table form that meets the accuracy target for the
 * operator, from a table of measured figures per operator and form (not a model: each figure is
 * the worst bench_target / bench_shifted measured, say which in cal_form_auto.c). */
#ifndef WDR_CAL_FORM_AUTO_H
#define WDR_CAL_FORM_AUTO_H

/* One form's measured figures for one operator (spline model, 19 levels). */
typedef struct wdr_form_figure {
    int op; /* operator id (wdr_lut.h) */
    int form, n_coeffs;
    double bytes_px;    /* table bytes per pixel (coefficients + flag byte) */
    double analog_pct;  /* worst analog contrast error, % (worst over the chips measured) */
    double floor_ratio; /* worst 12-bit error over the quantisation floor; NAN where not measured */
} wdr_form_figure;

/* The target: analog <= analog_pct and, where measured, <= floor_ratio x the floor. */
typedef struct wdr_form_target {
    double analog_pct, floor_ratio;
} wdr_form_target;

#define WDR_FORM_TARGET_DEFAULT ((wdr_form_target){1.0, 1.2})
#define WDR_FORM_AUTO_MAX 8

extern const wdr_form_figure wdr_form_figures[];
extern const int wdr_form_figures_n;

/* 1 when f meets t. */
int wdr_form_meets(const wdr_form_figure *f, wdr_form_target t);

/* The first form of op in table (n rows, each operator's forms smallest first) that meets t; the
 * ones before it that did not go to rejected (up to WDR_FORM_AUTO_MAX, *n_rejected of them).
 * @return the chosen row, or NULL when no form of op meets t (or op has none). */
const wdr_form_figure *wdr_form_auto(const wdr_form_figure *table, int n, int op, wdr_form_target t,
                                     const wdr_form_figure **rejected, int *n_rejected);

#endif
