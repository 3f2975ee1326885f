/* Figures of merit: FPN contrast error (the spread across pixels of (x_hat - x) / x, in %),
 * model error in mV, EMVA 1288 style DSNU and PRNU. */
#ifndef WDR_CAL_METRICS_H
#define WDR_CAL_METRICS_H
#include "cal_fit.h"
#include "wdr_cal.h"

typedef struct wdr_fpn_stats {
    double x;          /* true photocurrent (A) */
    double sd_pct;     /* spread across pixels: standard deviation of (x_hat - x)/x, % */
    double mean_pct;   /* common bias, % */
    double max_abs_pct;/* worst pixel |x_hat - x|/x, % */
    long used, excluded; /* pixels counted, flagged pixels left out */
    long nonfinite;    /* outputs that were NaN or Inf (must stay 0) */
} wdr_fpn_stats;

enum wdr_fpn_path {
    WDR_PATH_RAW = 0,   /* before correction: nominal inverse of the raw code */
    WDR_PATH_MODEL = 1, /* the model's own inverse in double (eq. 26) */
    WDR_PATH_TABLE = 2  /* the firmware kernel in float32, then the nominal inverse of its output */
};

/* Contrast error of one uniform frame at current x through a path. flags (may be NULL) marks
 * pixels left out, and on the table path so do the table's own flags; tab is needed for
 * WDR_PATH_TABLE. rel_err (may be NULL) gets every pixel's
 * (x_hat - x)/x (NAN for excluded pixels), for histograms. @retval WDR_OK, WDR_E_INVAL, WDR_E_NOMEM */
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
