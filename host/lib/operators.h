/* Tone-mapping operators: monotone curves T(L_w) in [0, 1] of world luminance L_w (cd/m2).
 * Shared by wdrctl (ramp tables, software tone mapping) and the simulator. */
#ifndef WDR_OPERATORS_H
#define WDR_OPERATORS_H
#include "wdr_lut.h"

#define WDR_OP_MAX_PARAMS WDR_LUT_NPARAMS
#define WDR_USER_CURVE_MAX 4096

typedef struct wdr_lum_stats {
    double l_avg;  /* log-average world luminance */
    double l_max;  /* maximum world luminance */
    double l_min;  /* minimum (positive) world luminance */
} wdr_lum_stats;

typedef struct wdr_operator {
    int id;                              /* enum wdr_operator_id */
    double p[WDR_OP_MAX_PARAMS];         /* parameters, meaning per operator */
    wdr_lum_stats stats;
    /* user curve: strictly increasing ln L knots with display values in [0,1] */
    int n_knots;
    double knot_ln_l[WDR_USER_CURVE_MAX];
    double knot_t[WDR_USER_CURVE_MAX];
} wdr_operator;

typedef struct wdr_param_info {
    const char *name;
    double def;         /* default; NaN = taken from the scene statistics */
    double min, max;    /* valid range, inclusive */
    const char *doc;
} wdr_param_info;

typedef struct wdr_operator_info {
    int id;
    const char *name;
    const char *doc;
    int n_params;
    wdr_param_info params[WDR_OP_MAX_PARAMS];
} wdr_operator_info;

/* The table of operators, indexed by id. */
const wdr_operator_info *wdr_operator_info_by_id(int id);
const wdr_operator_info *wdr_operator_info_by_name(const char *name);

/* Set op to operator `name` with default parameters and the given scene statistics.
 * @retval WDR_OK, WDR_E_INVAL (unknown name; err names it and lists the known ones) */
int wdr_operator_init(wdr_operator *op, const char *name, const wdr_lum_stats *stats, char *err, int errlen);

/* Set one parameter from "key=value" text. @retval WDR_OK, WDR_E_INVAL (err names key and value) */
int wdr_operator_set_param(wdr_operator *op, const char *key_value, char *err, int errlen);

/* Check every parameter and statistic: finite and in range. */
int wdr_operator_validate(const wdr_operator *op, char *err, int errlen);

/* Load a user curve: CSV with a header line and columns luminance,display (cd/m2, 0..1).
 * @retval WDR_OK, WDR_E_IO, WDR_E_INVAL (empty, non-monotone, NaN; err names file, line, value) */
int wdr_operator_load_curve(wdr_operator *op, const char *path, char *err, int errlen);

/* T(L_w) in [0,1]; finite for every finite L_w >= 0. */
double wdr_operator_eval(const wdr_operator *op, double l_w);

/* Scene statistics from a luminance image; non-finite pixels are skipped and values at or below
 * zero are guarded (a small floor), as lossy HDR files contain small negatives.
 * @retval number of pixels used, or WDR_E_INVAL when none is usable */
int wdr_lum_stats_measure(const float *lum, long n, wdr_lum_stats *out);

/* Default statistics for a board's photocurrent range: L = lum_per_A * I, L_avg chosen so that
 * Reinhard's scaled luminance is 1 at the centre current (the paper's 1.5 ms ramp). */
void wdr_lum_stats_default(double i_min, double i_center, double i_max, double lum_per_amp, double key,
                             wdr_lum_stats *out);

#endif
