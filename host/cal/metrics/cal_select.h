/* Choosing calibration currents, and judging a calibration on the frames of a source.
 * The paper's dark-region artefacts came from arbitrary currents: here the currents are the set
 * (from a grid of measured levels) that minimises the worst contrast error over the range. */
#ifndef WDR_CAL_SELECT_H
#define WDR_CAL_SELECT_H
#include "cal_engine.h"
#include "cal_fit.h"
#include "cal_metrics.h"

typedef struct wdr_cal_choice {
    int n;                       /* levels chosen (the dark reference first, when used) */
    int idx[WDR_CAL_MAX_LEVELS]; /* grid indices; -1 is the dark frame */
    double amps[WDR_CAL_MAX_LEVELS];
    double worst_pct; /* worst contrast error (sd, %) over the grid in range */
    double worst_at;  /* current where it happens (A) */
    long tried;       /* candidate sets evaluated */
    long judged;      /* sampled pixels worst_pct was judged on, and of them those */
    long left_out;    /* the chosen set's fit flagged, which worst_pct leaves out */
    /* The paper models (simple3, complex4): pixels the model left unfit, by reason, on the sample
     * that chose the set, then on the whole probe (the chosen set checked before the user spends
     * the calibration's frames on it) */
    long sampled, sampled_unfit, probe_px, probe_unfit;
    long by_status[WDR_FIT_COUNT]; /* the probe's, or the sample's when refused on it */
} wdr_cal_choice;

/* The most pixels (ppm) a paper model may leave unfit on the probe with the chosen set: more, and
 * the selection refuses, naming the reason, rather than flag that many healthy pixels. */
#define WDR_CAL_SELECT_MAX_UNFIT_PPM 10.0

/* Pick n_currents calibration currents from grid (levels rising; its dark frame is the dark
 * reference when cfg->use_dark_ref) that minimise the worst contrast error over the grid levels
 * in [x_lo, x_hi], judged on up to sample_pixels pixels spread over the array. Paper models with
 * their parameter count (3 or 4) search every subset (of a thinned grid when there are too many);
 * with more levels, and the curve models, log-spaced sets spanning the range with their density
 * warped towards either end.
 * @retval WDR_OK, WDR_E_INVAL (too few grid levels, err says so), WDR_E_NOMEM, WDR_E_NUMERIC */
int wdr_cal_select_currents(const wdr_cal_levels *grid, const wdr_cal_config *cfg, int n_currents, double x_lo,
                            double x_hi, int sample_pixels, wdr_cal_choice *out, char *err, int errlen);
/* For the paper models the selection also refuses (WDR_E_NUMERIC, err names the reason and the
 * count) when the model cannot serve the response it probed: candidate sets are ranked by the
 * pixels the model leaves unfit on the sample first, their worst contrast error second; the best
 * ones are fitted on the whole probe, and the first that leaves at most
 * WDR_CAL_SELECT_MAX_UNFIT_PPM unfit is chosen. */

/* Can cfg->model serve the response of design d at all? Checked before any frame is taken (the
 * design is the board's mismatch-free pixel under the operator): a one-pixel probe made of the
 * design's codes on the board's grid (6 levels per decade over its photocurrent range, and its dark
 * reading) goes through the informative range (min_slope), and the selection of n_currents; with
 * amps given (n_amps > 0, the user's levels) the model is fitted through them instead. Curve
 * models: always WDR_OK. @retval WDR_OK, WDR_E_NUMERIC (err: the reason, "known from the design"),
 * WDR_E_NOMEM */
int wdr_cal_design_check(const struct wdr_cal_design *d, const wdr_cal_config *cfg, int n_currents, const double *amps,
                         int n_amps, double min_slope, char *err, int errlen);

/* Levels for wdr_cal_fit_array from a choice (dark reference included), sharing no memory
 * with grid except the dark frame pointer. Free with wdr_cal_levels_free after clearing ->dark. */
int wdr_cal_levels_from_choice(const wdr_cal_levels *grid, const wdr_cal_choice *c, wdr_cal_levels *out);

/* The range of currents over which the array's median response carries contrast: where
 * |dy/d ln x| >= min_slope codes (below that, 1 % of contrast is less than min_slope/100 codes).
 * From the grid's medians; [*lo, *hi] within the grid. @retval WDR_OK, WDR_E_NUMERIC (nowhere) */
int wdr_cal_informative_range(const wdr_cal_levels *grid, double min_slope, double *lo, double *hi);

/* Contrast error through the three paths at n currents captured from src (one frame each).
 * raw, model and table get n stats each (any may be NULL). @retval WDR_OK or the source's error */
int wdr_cal_evaluate(const wdr_cal_result *res, const wdr_cal_view *tab, const wdr_cal_source *src, const double *amps,
                     int n, wdr_fpn_stats *raw, wdr_fpn_stats *model, wdr_fpn_stats *table);

#endif
