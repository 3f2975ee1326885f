/* Array calibration: per-pixel fits of a model, the nominal (array) curve, and the firmware table
 * built from them. Inputs are averaged frames at known photocurrents (wdr_cal_levels,
 * cal_levels.h) with their statistics and bad pixels (cal_stats.h, included); nothing here knows
 * how the frames were made. */
#ifndef WDR_CAL_FIT_H
#define WDR_CAL_FIT_H
#include "cal_model.h"
#include "cal_stats.h"
#include "wdr_cal.h"
#include <stddef.h>
#include <stdint.h>

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

/* Median response per level over the pixels not flagged (flags NULL: all). @retval WDR_OK, WDR_E_NOMEM */
int wdr_cal_level_medians(const wdr_cal_levels *lv, const uint8_t *flags, double *med);

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
