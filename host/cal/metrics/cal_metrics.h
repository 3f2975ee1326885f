/* Figures of merit of a calibration, one implementation for `wdrctl fpn report`,
 * `wdrctl calibrate --json`, the benchmarks and the accuracy-cost study.
 *
 * Every figure starts from the photocurrent each pixel's code stands for, x_hat, against the true
 * uniform current x of the frame:
 *   contrast error  100 * sd over pixels of ln(x_hat / x), in % (for small errors the same as the
 *                   sd of (x_hat - x)/x; unlike it, it stays meaningful for a raw, uncorrected
 *                   frame, where pixels sit a factor off)
 *   beyond          pixels whose x_hat lies outside the curve's calibrated range [x_lo, x_hi]
 *                   (their code is past the curve's end: an extrapolation), counted in the spread;
 *   unresolved      pixels with no usable x_hat (non-finite, or more than a decade outside
 *                   [x_lo, x_hi]: clamped inverses), left out of the spread and counted
 *   display error   8-bit display levels, 255 T(k x)^(1/gamma) through the operator T and the
 *                   display gamma, of x_hat against x: what a viewer sees (per decade, with the
 *                   fraction of pixels more than one level off)
 *   total error     FPN plus temporal noise at a number of averaged frames
 *   quantisation floor  the contrast error that rounding alone leaves where the response falls
 *                   at a given slope (codes per unit of ln x)
 *
 * Typical use (one uniform frame at current x):
 *     wdr_fpn_recover(res, tab, WDR_PATH_TABLE, frame, res->flags, x_hat);
 *     wdr_contrast_of(x_hat, np, x, res->nominal.x_lo, res->nominal.x_hi, &c);
 *     wdr_display_error_of(x_hat, np, x, &display, &d);
 * All functions are pure computations on caller memory except where they say they allocate. */
#ifndef WDR_CAL_METRICS_H
#define WDR_CAL_METRICS_H
#include "board.h"
#include "cal_design.h"
#include "cal_engine.h"
#include "cal_fit.h"
#include "operators.h"
#include "wdr_cal.h"

/* ---- x_hat: the current each pixel's code stands for ---- */

enum wdr_fpn_path {
    WDR_PATH_RAW = 0,   /* before correction: the nominal curve's inverse of the raw code */
    WDR_PATH_MODEL = 1, /* the model's own inverse in double (eq. 26) */
    WDR_PATH_TABLE = 2  /* the firmware kernel in float32, then the nominal inverse of its output */
};

/* x_hat of every pixel of frame (width * height of res) through a path into x_hat (NAN where flags
 * (may be NULL) or, on the table path, the table's own flags leave the pixel out). tab is needed
 * for WDR_PATH_TABLE. @retval WDR_OK, WDR_E_INVAL (path without its table), WDR_E_NOMEM */
int wdr_fpn_recover(const wdr_cal_result *res, const wdr_cal_view *tab, int path, const float *frame,
                    const uint8_t *flags, double *x_hat);

/* ---- contrast error ---- */

typedef struct wdr_contrast {
    double x;           /* true photocurrent (A) */
    double sd_pct;      /* 100 * sd of ln(x_hat / x) over the resolved pixels */
    double mean_pct;    /* 100 * mean of ln(x_hat / x): the common bias */
    double max_abs_pct; /* 100 * worst |ln(x_hat / x)| */
    long used;          /* resolved pixels, counted in the spread */
    long beyond;        /* of them, outside [x_lo, x_hi] */
    long unresolved;    /* left out: non-finite or more than a decade outside [x_lo, x_hi] */
    long excluded;      /* left out by flags (x_hat NAN on input) */
    double beyond_frac; /* (beyond + unresolved) / (used + unresolved): pixels past the curve */
} wdr_contrast;

/* Contrast error of n recovered currents (NAN: excluded pixel) at true current x, for a curve
 * calibrated over [x_lo, x_hi]. */
void wdr_contrast_of(const double *x_hat, long n, double x, double x_lo, double x_hi, wdr_contrast *out);

/* ---- total error: FPN plus temporal noise ---- */

typedef struct wdr_total_error {
    double x;
    double fpn_pct;      /* fixed-pattern part: sqrt(total_1^2 - temporal^2) */
    double temporal_pct; /* one frame's temporal part: 100 * sd of ln(x_a / x_b) / sqrt 2 */
    double total_1_pct;  /* one frame, FPN plus temporal (contrast error of frame a) */
    int frames;          /* frames averaged for total_m_pct */
    double total_m_pct;  /* contrast error of the average of `frames` frames, measured */
    long left_out;       /* pixels left out of total_1 (excluded or unresolved in frame a) */
} wdr_total_error;

/* From x_hat of two independent single frames a and b and of an average of `frames` frames
 * (x_hat_m; may equal x_hat_a when frames is 1), all at current x. */
void wdr_total_error_of(const double *x_hat_a, const double *x_hat_b, const double *x_hat_m, long n, int frames,
                        double x, double x_lo, double x_hi, wdr_total_error *out);

/* ---- display-space error ---- */

typedef struct wdr_display_map {
    wdr_operator op;    /* the tone-mapping operator T */
    double lum_per_amp; /* k: luminance per ampere of photocurrent */
    double gamma;       /* display gamma (2.2) */
} wdr_display_map;

/* The map for board b under operator op_name with default parameters (as `wdrctl lut build`).
 * @retval WDR_OK or the operator's error (err names it) */
int wdr_display_map_init(wdr_display_map *d, const wdr_board *b, const char *op_name, char *err, int errlen);

/* Continuous 8-bit display level of current x: 255 T(k x)^(1/gamma) (not rounded). */
double wdr_display_level(const wdr_display_map *d, double x);

typedef struct wdr_display_error {
    double x_lo, x_hi;      /* currents covered (one current, or a decade) */
    double mean_levels;     /* mean of level(x_hat) - level(x): the bias a viewer sees as a whole */
    double mean_abs_levels; /* mean |level(x_hat) - level(x)| */
    double rms_levels;      /* rms of level(x_hat) - level(x) */
    double frac_over_1;     /* fraction of pixels more than one level off */
    long used;
} wdr_display_error;

/* Display error of n recovered currents (NAN: excluded) at true current x. */
void wdr_display_error_of(const double *x_hat, long n, double x, const wdr_display_map *d, wdr_display_error *out);

/* Pool per-current display errors e[0..n-1] (rising x) into decades [10^k, 10^(k+1)) A, weighted by
 * their pixel counts; out gets at most max_out decades. @return the number of decades */
int wdr_display_by_decade(const wdr_display_error *e, int n, wdr_display_error *out, int max_out);

/* The nominal response as a table for the display mapping of corrected codes (host/lib/tonemap.h,
 * wdr_response_curve): n points per_decade over [x_lo, x_hi] of the nominal widened by half a
 * decade each side (the curve's own extension), ln x rising, codes falling. At 64 per decade,
 * interpolating linearly in ln x stays within 0.1 code of the curve. @return the number of points
 * (at most max; 0 when the curve does not fall strictly there) */
int wdr_nominal_response_table(const wdr_nominal *nom, int per_decade, double *ln_x, double *code, int max);

/* ---- quantisation floor ---- */

/* Contrast error (%) that rounding alone leaves on a pixel read at slope |dy/d ln x| codes per
 * unit of ln x: 100 * q / slope with q = sqrt(2 (1 + s^2) / 12) codes rms: the ADC's rounding
 * (1 LSB) and a DAC step of s ADC codes held as a uniform error, once in the frame and once in the
 * calibration levels the pixel's curve passes through. With converters off the floor is 0. */
double wdr_quant_floor_pct(double log_slope_codes, double dac_step_codes);

/* ---- everything at one current, from a frame source ---- */

typedef struct wdr_eval_opts {
    int frames;                     /* frames averaged per evaluation frame (the calibration's M; 1 without noise) */
    int temporal;                   /* 1: the source has temporal noise: two more single frames give the total error */
    int quantised;                  /* 1: converters on: the quantisation floor is computed, else it is 0 */
    const wdr_display_map *display; /* may be NULL: no display error */
    const wdr_cal_design *design;   /* slope and DAC step for the floor (NULL: the nominal's slope, 1 code) */
    int first_frame_no;             /* frame numbers (seeds) used: first_frame_no .. + frames + 2 */
} wdr_eval_opts;

typedef struct wdr_eval_point {
    double x;
    wdr_contrast before;   /* raw codes through the nominal inverse (of the averaged frame) */
    wdr_contrast model;    /* the model's own inverse in double */
    wdr_contrast table;    /* the firmware table in float32 (what the product delivers) */
    wdr_total_error total; /* table path: FPN, temporal, totals at 1 and `frames` frames (without temporal
                              noise all of it is FPN) */
    wdr_display_error display, display_before; /* table path and raw, in 8-bit levels */
    double floor_pct;                          /* quantisation floor at x (0 with converters off) */
} wdr_eval_point;

/* Capture at uniform current x from src (an average of o->frames frames, and with o->temporal two
 * single frames) and measure everything above. tab may be NULL (no table path; table and total
 * stay zero). @retval WDR_OK, WDR_E_NOMEM, or the source's error */
int wdr_eval_point_measure(const wdr_cal_result *res, const wdr_cal_view *tab, const wdr_cal_source *src, double x,
                           const wdr_eval_opts *o, wdr_eval_point *out);

/* ---- the older per-frame summary (selection, torture tests) ---- */

typedef struct wdr_fpn_stats {
    double x;            /* true photocurrent (A) */
    double sd_pct;       /* spread across pixels: standard deviation of (x_hat - x)/x, % */
    double mean_pct;     /* common bias, % */
    double max_abs_pct;  /* worst pixel |x_hat - x|/x, % */
    long used, excluded; /* pixels counted, flagged pixels left out */
    long nonfinite;      /* outputs that were NaN or Inf (must stay 0) */
} wdr_fpn_stats;

/* Contrast error of one uniform frame at current x through a path, as (x_hat - x)/x. flags (may be
 * NULL) marks pixels left out, and on the table path so do the table's own flags. rel_err (may be
 * NULL) gets every pixel's (x_hat - x)/x in % (NAN for excluded pixels), for histograms.
 * @retval WDR_OK, WDR_E_INVAL, WDR_E_NOMEM */
int wdr_fpn_frame(const wdr_cal_result *res, const wdr_cal_view *tab, int path, const float *frame, double x,
                  const uint8_t *flags, double *rel_err, wdr_fpn_stats *out);

/* Largest |model response - measured| over pixels and test frames, in codes, for unflagged
 * pixels (LSQ: the map's residual |P(y) - nominal(x)|). frames: n frames at amps. Also the median
 * over pixels of each pixel's worst error. */
void wdr_model_error(const wdr_cal_result *res, const float *frames, const double *amps, int n, const uint8_t *flags,
                     double *max_codes, double *median_codes);

/* DSNU: spread of the dark frame (codes); PRNU: spread of (y_dark - y) / mean(y_dark - y) at one
 * illuminated level, %. Both over unflagged pixels, from frames already averaged over time. */
void wdr_emva_nonuniformity(const float *dark, const float *lit, long np, const uint8_t *flags, double *dsnu_codes,
                            double *prnu_pct);

#endif
