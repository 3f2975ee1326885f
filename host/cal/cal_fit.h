/* Array calibration: bad-pixel detection, per-pixel fits of a model, the nominal (array) curve,
 * and the firmware table built from them. Inputs are averaged frames at known photocurrents
 * (wdr_cal_levels); nothing here knows how the frames were made. */
#ifndef WDR_CAL_FIT_H
#define WDR_CAL_FIT_H
#include "cal_model.h"
#include "wdr_cal.h"
#include <stdint.h>

#define WDR_CAL_MAX_LEVELS 48
#define WDR_PCHIP_MAX 64

/* Averaged frames: frames[k * width * height + pixel] is the mean code at amps[k]. Levels rise
 * strictly in amps; dark (may be NULL) is a frame with no light, used for hot pixels and DSNU. */
typedef struct wdr_cal_levels {
    int width, height, n;
    double amps[WDR_CAL_MAX_LEVELS];
    float *frames;
    float *dark;
    /* Temporal noise measured from the frames themselves (wdr_cal_acquire with m_avg >= 2):
     * noise[k] is one frame's sd at level k (codes, RMS over the array), dark_noise the dark
     * frame's; m_avg frames were averaged. m_avg 0: not measured (ties judged by tie_codes alone). */
    double noise[WDR_CAL_MAX_LEVELS], dark_noise;
    int m_avg;
} wdr_cal_levels;

/* A monotone curve through (ln x_k, y_k): the array's median response (PCHIP, Fritsch-Carlson). */
typedef struct wdr_pchip {
    int n;
    double lx[WDR_PCHIP_MAX], y[WDR_PCHIP_MAX], m[WDR_PCHIP_MAX];
} wdr_pchip;

struct wdr_cal_design;

/* The nominal pixel: what a corrected pixel reports for current x. */
typedef struct wdr_nominal {
    int model; /* enum wdr_cal_model_id: SIMPLE3 and COMPLEX4 use their model, LSQ/POLYMAP the PCHIP */
    wdr_simple3 s3;
    wdr_complex4 c4;
    wdr_pchip curve;
    double x_lo, x_hi; /* calibrated range (A) */
    /* curves: slope at the first and last knot over the secant to its neighbour, from the designed
       response (cal_design.h); 0: three-point estimates from the knots alone */
    double end_ratio[2];
    double y_top;      /* LSQ: the nominal level at zero current (the lowest two levels' secant) */
    /* LSQ: ln x at codes z0 + k dz, a starting point that one Newton step on the curve polishes */
    double *inv_lx, inv_z0, inv_dz;
    int inv_n;
} wdr_nominal;

double wdr_nominal_eval(const wdr_nominal *n, double x);
/* Current for response y (0 or x_hi * 10 at the ends; never NaN). */
double wdr_nominal_invert(const wdr_nominal *n, double y);
/* |dy / d ln x| at x: codes per unit of ln x, the scale that turns code errors into contrast. */
double wdr_nominal_log_slope(const wdr_nominal *n, double x);

typedef struct wdr_cal_config {
    int model;          /* enum wdr_cal_model_id */
    int form;           /* enum wdr_cal_form of the table */
    int n_coeffs;       /* POLY table: coefficients (degree + 1); POLYMAP fits this many directly */
    int use_dark_ref;   /* SIMPLE3/COMPLEX4: level 0 is the dark-end reference for d (eq. 20) */
    double raw_max;     /* largest raw code */
    float out_scale;    /* output code per raw code unit (default 1: frames keep the ADC's range) */
    uint16_t out_max;   /* largest output code (default raw_max * out_scale) */
    double stuck_frac, dead_frac, hot_frac; /* bad-pixel thresholds (see cal_fit.c) */
    double max_residual;       /* LSQ/POLYMAP: most rms residual (ln x) the model's own misfit on a chip may excuse;
                                  a pixel is unfit beyond tie_sigmas sigma of its noise plus that misfit
                                  (host/cal/cal_residual.c; default 0.5, healthy pixels measured <= 0.21) */
    double range_lo, range_hi; /* currents the table must serve (A); 0: the calibration currents' span */
    double tie_codes;   /* SPLINE/LSQ curves: neighbouring levels closer than this are quantisation ties
                           (default 0.5, half an ADC code; about 1e-3 for unquantised data) */
    const struct wdr_cal_design *design; /* the designed response (may be NULL): curve models take
                           their end slopes from its shape instead of three-point estimates */
    double code_noise;  /* rms uncertainty of a calibration level's code (codes): rounding of the ADC
                           and DAC, temporal noise left after averaging. 0: auto, the levels'
                           measured noise over sqrt(M), with the converters' rounding when the
                           levels are whole codes */
    double tie_sigmas;  /* k: a reversal counts only beyond tie_codes + k sigma sqrt(2/M) of the measured
                           temporal noise (default 5: about 3e-7 false reversals per pair of levels) */
    double step_codes;  /* smallest response step the ramp resolves (one DAC step, codes; 0: unknown):
                           selected levels are spaced by more than this plus spacing_sigmas sigma */
    double spacing_sigmas; /* default 3 */
} wdr_cal_config;

/* Tolerance for a reversal between levels k-1 and k (codes): tie_codes plus tie_sigmas times the
 * sd of the difference of two M-frame means, from the levels' measured noise. */
double wdr_cal_tie_tolerance(const wdr_cal_levels *lv, const wdr_cal_config *cfg, int k);
/* sd of one level's M-frame mean (codes; 0 when the noise was not measured). */
double wdr_cal_level_sd(const wdr_cal_levels *lv, int k);

/* Decreasing isotonic regression (pool-adjacent-violators) of y[0..n-1] with weights w (> 0):
 * out is the closest non-increasing sequence in weighted least squares. */
void wdr_cal_isotonic_falling(const double *y, const double *w, int n, double *out);

/* Frames per level for a calibration (`--frames auto`), from a probe that measured the noise
 * (m_avg >= 2): the fewest M for which every level in [lo, hi] has sigma / sqrt(M) below its
 * wanted error, target_pct of contrast (codes: target x the median's slope in ln x) but never
 * finer than half the quantisation floor lsb / sqrt(12) (lsb 0: unquantised). at_amps names the
 * level that decided, with its sigma, slope and wanted error. At least 2, at most max_frames. */
/* Median response per level over the pixels not flagged (flags NULL: all). @retval WDR_OK, WDR_E_NOMEM */
int wdr_cal_level_medians(const wdr_cal_levels *lv, const uint8_t *flags, double *med);

typedef struct wdr_cal_frames_choice {
    int frames, capped, needed; /* needed: the frames the target asks for, before the cap */
    double target_pct, at_amps, sigma_codes, slope, want_codes;
} wdr_cal_frames_choice;
int wdr_cal_frames_for(const wdr_cal_levels *probe, const double *med, double lo, double hi, double lsb,
                       double target_pct, int max_frames, wdr_cal_frames_choice *out);

void wdr_cal_config_defaults(wdr_cal_config *c, int model);

/* Per-pixel result of a calibration. */
typedef struct wdr_cal_result {
    int width, height, model;
    wdr_cal_config cfg;
    wdr_nominal nominal;
    double x_scale;
    int n_params;
    double *params;   /* n_params per pixel: model parameters, LSQ basis weights or POLYMAP coefficients */
    uint8_t *flags;   /* WDR_PIX_* per pixel */
    uint8_t *status;  /* enum wdr_fit_status per pixel (UNFIT reason) */
    long n_flag[8];   /* pixels per flag bit */
    long n_status[WDR_FIT_COUNT];
    long n_bad;
    int saturated_levels; /* levels where the array median sits at a rail */
    int m_avg;            /* frames the levels averaged (0: not measured); the paper fits judge a dark reading by one frame's noise */
    double code_noise;    /* rms uncertainty of a level's code used by the tables' fits (cfg.code_noise
                             or its auto value) */
} wdr_cal_result;

/* Detect dead, stuck, hot and saturated pixels into flags (width*height, zeroed first). */
void wdr_cal_detect_bad(const wdr_cal_levels *lv, const wdr_cal_config *cfg, uint8_t *flags, int *saturated_levels);

/* Fit every pixel. levels: SIMPLE3 needs at least 3 (+1 dark-end reference first with
 * use_dark_ref), COMPLEX4 4 (+1): exactly that many is the paper's exact fit, more a least-squares
 * fit on the code residuals (wdr_simple3_fit_lsq, wdr_complex4_fit_lsq), LSQ at least WDR_LSQ_PARAMS + 2, POLYMAP at least n_coeffs + 1.
 *
 * LSQ is least squares on a basis that follows from the pixel physics. A pixel whose photodiode
 * capacitance, reset level, M2 threshold, dark current and source-follower offset differ from
 * nominal recovers x = k1 I'(z) + (k2 + k3 s(z)^2) I'(z) / D(z) + k4 with z = y - o, where I'(z)
 * is the nominal inverse (monotone cubic through the array medians), D(z) = y_top - z the
 * nominal swing from dark through which the reset and threshold offsets act (I'/D is one over
 * the ramp time at that level), s(z) the level scaled to [0, 1] (the junction capacitance
 * changes along the swing; a linear term would repeat I' = D I'/D), k4 the dark current and o the source-follower offset.
 * k1..k4 are linear (QR) for a given o; o is found by a 1-D search (variable projection).
 * Residuals are relative, so the fit minimises the contrast error itself.
 * @retval WDR_OK
 * @retval WDR_E_INVAL   wrong level count, levels not rising, bad config (err says which)
 * @retval WDR_E_NUMERIC the nominal curve itself cannot be fitted (err names the reason)
 * @retval WDR_E_NOMEM */
int wdr_cal_fit_array(const wdr_cal_levels *lv, const wdr_cal_config *cfg, wdr_cal_result *res, char *err,
                      int errlen);
void wdr_cal_result_free(wdr_cal_result *res);

/* Recovered photocurrent (A) of pixel i for raw code y, by the model in double: its inverse
 * for SIMPLE3/COMPLEX4 (eq. 26), the nominal inverse of the fitted map for LSQ. Never NaN;
 * *status gets a failure reason (0 when fine). */
double wdr_cal_recover(const wdr_cal_result *res, long i, double y, int *status);

/* The corrected value (raw-code units, before out_scale) of pixel i: nominal(recovered x). */
double wdr_cal_map(const wdr_cal_result *res, long i, double y);

/* Build the firmware table (form from cfg) into a malloc'd buffer (4-byte aligned).
 * Pixels whose coefficients would not be finite or whose MOEBIUS denominator could vanish get
 * identity coefficients and WDR_PIX_UNFIT. @retval WDR_OK, WDR_E_NOMEM, WDR_E_INVAL */
int wdr_cal_build_table(const wdr_cal_result *res, uint32_t sensor_id, int operator_id, uint8_t **out,
                        size_t *out_len, char *err, int errlen);

#define WDR_LSQ_PARAMS 5

/* Monotone interpolation helpers (exposed for tests). */
int wdr_pchip_init(wdr_pchip *p, const double *lx, const double *y, int n);
/* The same with end slopes end_ratio[0] * first secant and end_ratio[1] * last secant (a ratio of 0
 * keeps the three-point estimate); where they would break monotonicity the PCHIP end is used. */
int wdr_pchip_init_ends(wdr_pchip *p, const double *lx, const double *y, int n, const double *end_ratio);
double wdr_pchip_eval(const wdr_pchip *p, double lx);
double wdr_pchip_slope(const wdr_pchip *p, double lx);
/* ln x where the curve reaches y (linear beyond the ends; the curve must be strictly monotone). */
double wdr_pchip_invert(const wdr_pchip *p, double y);

#endif
