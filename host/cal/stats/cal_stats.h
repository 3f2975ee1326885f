/* Calibration statistics: the configuration, the levels' noise and the tolerances it sets,
 * isotonic pooling, frames per level, bad pixels (cal_stats.c, cal_bad.c). The fits (cal_fit.h)
 * build on these; nothing here calls a fit. */
#ifndef WDR_CAL_STATS_H
#define WDR_CAL_STATS_H
#include "cal_levels.h"
#include "wdr_cal.h"
#include <stddef.h>
#include <stdint.h>

struct wdr_cal_design;

typedef struct wdr_cal_config {
    int model;                              /* enum wdr_cal_model_id */
    int form;                               /* enum wdr_cal_form of the table */
    int n_coeffs;                           /* POLY table: coefficients (degree + 1); POLYMAP fits this many directly */
    int use_dark_ref;                       /* SIMPLE3/COMPLEX4: level 0 is the dark-end reference for d (eq. 20) */
    double raw_max;                         /* largest raw code */
    float out_scale;                        /* output code per raw code unit (default 1: frames keep the ADC's range) */
    uint16_t out_max;                       /* largest output code (default raw_max * out_scale) */
    double stuck_frac, dead_frac, hot_frac; /* bad-pixel thresholds (see cal_bad.c) */
    double max_residual;       /* LSQ/POLYMAP: most rms residual (ln x) the model's own misfit on a chip may excuse;
                                  a pixel is unfit beyond tie_sigmas sigma of its noise plus that misfit
                                  (host/cal/fit/cal_residual.c; default 0.5, healthy pixels measured <= 0.21) */
    double range_lo, range_hi; /* currents the table must serve (A); 0: the calibration currents' span */
    double tie_codes;          /* SPLINE/LSQ curves: neighbouring levels closer than this are quantisation ties
                                  (default 0.5, half an ADC code; about 1e-3 for unquantised data) */
    const struct wdr_cal_design *design; /* the designed response (may be NULL): curve models take
                           their end slopes from its shape instead of three-point estimates */
    double code_noise;                   /* rms uncertainty of a calibration level's code (codes): rounding of the ADC
                                            and DAC, temporal noise left after averaging. 0: auto, the levels'
                                            measured noise over sqrt(M), with the converters' rounding when the
                                            levels are whole codes */
    double tie_sigmas;     /* k: a reversal counts only beyond tie_codes + k sigma sqrt(2/M) of the measured
                              temporal noise (default 5: about 3e-7 false reversals per pair of levels) */
    double step_codes;     /* smallest response step the ramp resolves (one DAC step, codes; 0: unknown):
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
typedef struct wdr_cal_frames_choice {
    int frames, capped, needed; /* needed: the frames the target asks for, before the cap */
    double target_pct, at_amps, sigma_codes, slope, want_codes;
} wdr_cal_frames_choice;
int wdr_cal_frames_for(const wdr_cal_levels *probe, const double *med, double lo, double hi, double lsb,
                       double target_pct, int max_frames, wdr_cal_frames_choice *out);

/* Detect saturated, stuck, dead and hot pixels into flags (width*height, zeroed first): one kind
 * per pixel, by the precedence in cal_bad.c. */
void wdr_cal_detect_bad(const wdr_cal_levels *lv, const wdr_cal_config *cfg, uint8_t *flags, int *saturated_levels);

/* The kinds of flag, by bit (WDR_PIX_DEAD = bit 0 .. WDR_PIX_UNFIT = bit 4), as the reports name
 * them; each pixel carries one. */
#define WDR_CAL_FLAG_KINDS 5
const char *wdr_cal_flag_name(int bit);
/* "dead D, stuck S, hot H, saturated A, unfit U" from the pixel counts per flag bit (a result's
 * n_flag) into buf. @return buf */
const char *wdr_cal_flag_counts_text(const long *n_flag, char *buf, size_t cap);
/* cal_bad.c: median of the finite values among n (scratch holds n floats). */
double wdr_cal_median_of(const float *v, long n, float *scratch);

/* Per level: the pair tolerances tol[k] (k-1, k) and weights 1/sd^2 for the falling fit. */
void wdr_cal_level_tolerances(const wdr_cal_levels *lv, const wdr_cal_config *cfg, double *tol, double *w);

#endif
