/* From an operator to a DAC ramp: V_ref(t) such that an ideal pixel holds g(I) =
 * v_dark - swing * T(k I), solved in ln I, then quantised into a LUT (SENSOR.md). */
#ifndef WDR_RAMP_H
#define WDR_RAMP_H
#include "board.h"
#include "operators.h"
#include "pixel.h"
#include <stdint.h>

typedef struct wdr_ideal_pixel {
    wdr_pixel_dev dev;
    double v_n0;     /* reset level */
    double q_n0;     /* charge at reset */
    double v_dark;   /* target level for no light */
    double swing;
    double lum_per_amp;
} wdr_ideal_pixel;

/* A sampled V_ref(t): n points, t rising, v rising (non-decreasing). */
typedef struct wdr_ramp {
    int n;
    double *t, *v, *ln_i;  /* time (s), V_ref (V), ln of the photocurrent that crosses there */
    double t_end;          /* integration time: crossing of the dimmest current */
    /* realisability */
    int repaired;          /* 1 if parts of the response were changed to make it realisable */
    double bad_i_lo, bad_i_hi; /* photocurrent range that was not realisable (0 if none) */
    double repair_max_dev_v;   /* worst change of the response made by the repair */
} wdr_ramp;

enum wdr_ramp_policy { WDR_RAMP_FAIL = 0, WDR_RAMP_REPAIR = 1 };

void wdr_ideal_pixel_init(const wdr_board *b, wdr_ideal_pixel *px);

/* Wanted pixel output for photocurrent i: g(I). */
double wdr_ideal_target(const wdr_ideal_pixel *px, const wdr_operator *op, double i);

/* Time at which an ideal pixel with current i reaches the M2 turn-off node for G = v_g. */
double wdr_ideal_cross_time(const wdr_ideal_pixel *px, double i, double v_g);

/* Build V_ref(t) over [i_min, i_max] with n_samples points (log-spaced in I).
 * @retval WDR_OK
 * @retval WDR_E_UNREALISABLE with policy FAIL: err names the failing photocurrent range
 * @retval WDR_E_NUMERIC  a non-finite value appeared
 * @retval WDR_E_NOMEM */
int wdr_ramp_build(const wdr_ideal_pixel *px, const wdr_operator *op, double i_min, double i_max, int n_samples,
                   int policy, wdr_ramp *out, char *err, int errlen);
void wdr_ramp_free(wdr_ramp *r);

/* V_ref at time t by interpolation (held flat outside the sampled range). */
double wdr_ramp_eval(const wdr_ramp *r, double t);

/* Quantise a ramp into a LUT for the board's DAC; out gets malloc'd bytes (free()).
 * timing: enum wdr_lut_timing; entries: for UNIFORM, the number of clock ticks (ignored for STAMPED).
 * @retval WDR_OK, WDR_E_TOO_LARGE (more than WDR_LUT_MAX_ENTRIES), WDR_E_NOMEM, WDR_E_INVAL */
int wdr_ramp_quantise(const wdr_ramp *r, const wdr_board *b, const wdr_operator *op, int timing,
                      uint32_t entries, uint8_t **out, size_t *out_len, char *err, int errlen);

/* Held G value of an ideal pixel with current i under a quantised LUT (step crossing). */
double wdr_ramp_lut_ideal_response(const wdr_ideal_pixel *px, const wdr_lut_view *lut, double i);

/* The same for many currents: the LUT's steps and the charge each needs (two pow() a step),
 * computed once. wdr_ramp_lut_ideal_response builds and frees them on every call. */
typedef struct wdr_lut_steps {
    uint32_t n;
    double *t0, *t1, *v, *need;
} wdr_lut_steps;
int wdr_lut_steps_init(const wdr_ideal_pixel *px, const wdr_lut_view *lut, wdr_lut_steps *s);
double wdr_lut_steps_response(const wdr_ideal_pixel *px, const wdr_lut_steps *s, double i);
void wdr_lut_steps_free(wdr_lut_steps *s);

/* Worst |response - g(I)| in DAC LSB over n log-spaced currents in [i_min, i_max];
 * *worst_i gets the current where it happens (may be NULL). */
double wdr_ramp_lut_worst_error_lsb(const wdr_ideal_pixel *px, const wdr_operator *op, const wdr_lut_view *lut,
                               double i_min, double i_max, int n, double *worst_i);

/* The exposure table of a LUT (LUT 1.1): per bin of corrected codes, ln(I / key_amp) * 256 of the
 * current whose ideal code is the bin's first code (a DAC step's code at the middle of the currents
 * it holds); key_amp is the log-average current the ramp was built for (L_avg / lum_per_A).
 * @retval WDR_OK, WDR_E_NOMEM */
int wdr_ramp_lut_exposure_table(const wdr_board *b, const wdr_lut_view *lut, double key_amp, wdr_lut_exposure *out);

/* The droop array of the exposure block at the end of the LUT in bytes, computed again for the
 * LUT's own integration time (in place, CRC too): calibrate's margin lengthens the integration
 * after the block was built, and every pixel then holds longer than the array says (at a tick
 * 19.5x its own, 0.3 codes more on Reinhard's sim-qvga, where a code near the ceiling is 0.1-0.5 ln).
 * @retval WDR_OK (also when there is no block, or no droop array), the parse errors, WDR_E_NOMEM */
int wdr_ramp_lut_refresh_droop(uint8_t *bytes, size_t len, const wdr_board *b);

/* Append that table to the LUT in *bytes (realloc'd; *len grows by WDR_LUT_EXPO_BLOCK_SIZE(bins), 1024 bins).
 * @retval WDR_OK, the wdr_lut_parse errors, WDR_E_NOMEM */
int wdr_ramp_lut_append_exposure(uint8_t **bytes, size_t *len, const wdr_board *b, double key_amp);

/* Build a LUT for board b from operator op_name with default parameters and the board's
 * photocurrent range and DAC timing (as `wdrctl lut build`). *bytes is malloc'd (free()).
 * ramp, if not NULL, receives the continuous ramp (wdr_ramp_free it), for wdr_sim_set_ramp.
 * @retval WDR_OK, or the operator/ramp errors (err says which) */
int wdr_ramp_board_lut(const wdr_board *b, const char *op_name, uint8_t **bytes, size_t *len,
                      wdr_ramp *ramp, char *err, int errlen);

#endif
