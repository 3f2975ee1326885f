/* The calibration margin sized from the chip's own frames (issue 19).
 *
 * A ramp built for [i_min, i_max] ends where the nominal pixel's dimmest current crosses. A pixel
 * whose reset level sits high or whose M2 threshold sits low starts its crossing above nominal
 * and, past the ramp's end, holds the last code: a flat response at the dim end. The margin
 * continues the ramp (wdr_cal_lut_extend) until the latest-crossing pixel of this chip crosses
 * at the dimmest level calibration takes.
 *
 * The margin probe measures that pixel on frames only: at the dimmest level a pixel holds its
 * crossing level (its reset level minus its M2 threshold, past the nominal ramp's end), at a
 * bright level it holds a level the offset barely moves; the difference of the two, per pixel,
 * takes its source follower's offset out. Its excess over the array's median, in volts through
 * the designed follower, is how much later than the median pixel it crosses; the largest excess
 * plus a guard is the margin. A pixel still at the ramp's top (its excess within the guard of the
 * margin in use) may lie further: the margin then grows, from the spread, and the probe is taken
 * again. Never the simulator's per-pixel parameters. */
#ifndef WDR_CAL_MARGIN_H
#define WDR_CAL_MARGIN_H
#include "cal_engine.h"

/* The first round's margin (the fixed margin of before: about six sigma of the 0.35 um defaults),
 * the most rounds, and the most integration time a margin may add (s): past it, refused. */
#define WDR_CAL_MARGIN_START_V 0.06
#define WDR_CAL_MARGIN_ROUNDS 5
#define WDR_CAL_MARGIN_MAX_S 1.0

/* What the probe measured and the margin it chose. */
typedef struct wdr_cal_margin {
    double margin_v;        /* the margin the LUT carries (whole DAC steps) */
    double added_s;         /* the integration time it adds to the ramp */
    double latest_v;        /* the latest-crossing pixel's crossing level above the median pixel's */
    double spread_v;        /* sd of the crossing level over the array (median to its 15.9th percentile) */
    double guard_v;         /* added to latest_v: 2 DAC steps, 5 sigma of one frame's noise, 5 % of latest_v */
    double dim_a, bright_a; /* the levels the probe took */
    long n_pixels;
    long n_late; /* pixels within the guard of the ramp's top in the last round (0 once sized) */
    int rounds;  /* probe rounds taken */
} wdr_cal_margin;

/* What the probe needs to know. */
typedef struct wdr_cal_margin_req {
    double dim_a;       /* the dimmest level calibration takes: the latest pixel must cross there */
    double bright_a;    /* a bright level (the brightest calibration takes), for the follower's offset */
    double codes_per_v; /* ADC codes per volt of the hold node at the dark end (the designed follower) */
    double dac_lsb_v;   /* one DAC step */
    int frames;         /* frames averaged per level (>= 2: the noise is measured) */
} wdr_cal_margin_req;

/* Puts a LUT with margin_v of calibration margin in front of the chip (the simulator's ramp, or a
 * board's stored LUT); *done_v and *added_s say what it realised.
 * @retval WDR_OK, or an error with err saying why (the time limit, the DAC's top code) */
typedef int (*wdr_cal_margin_set_fn)(void *ctx, double margin_v, double *done_v, double *added_s, char *err,
                                     int errlen);

/* From one round's frames (dim, bright: np pixels each; noise_codes: one frame's temporal sd at
 * the dim level) with margin_in_use_v on the ramp: latest_v, spread_v, guard_v, n_late and
 * margin_v (the margin the chip needs: latest + guard, or, with pixels late, a larger one to try:
 * at least 1.5x the margin in use and the spread's projection to the array's size).
 * @retval WDR_OK, WDR_E_NOMEM, WDR_E_INVAL (no response between the two levels) */
int wdr_cal_margin_measure(const float *dim, const float *bright, long np, double noise_codes,
                           const wdr_cal_margin_req *req, double margin_in_use_v, wdr_cal_margin *out);

/* Size the margin: set the start margin, probe (dim and bright, req->frames each), grow while
 * pixels are late (at most WDR_CAL_MARGIN_ROUNDS rounds), then set the margin measured.
 * @retval WDR_OK; WDR_E_INVAL when no margin within the limits lets every pixel cross (err says
 *         what the chip needs and what stopped it); the source's or the setter's error */
int wdr_cal_margin_size(const wdr_cal_source *src, const wdr_cal_margin_req *req, wdr_cal_margin_set_fn set, void *ctx,
                        wdr_cal_margin *out, char *err, int errlen);

/* The LUT in, continued by margin_v at its final slope with no time limit but
 * WDR_CAL_MARGIN_MAX_S; refused (WDR_E_INVAL, err says what stopped it) when the DAC's top code
 * or that limit leaves more than half a DAC step of the margin undone. *out is malloc'd. */
int wdr_cal_lut_with_margin(const uint8_t *in, size_t in_len, double margin_v, uint8_t **out, size_t *out_len,
                            double *added_s, double *done_v, char *err, int errlen);

/* The simulator's setter (cal_engine.c): ctx is a wdr_cal_sim_margin; each call builds the board's
 * LUT for the operator, adds the margin (wdr_cal_lut_with_margin) and sets it on the chip; lut
 * holds the bytes in use (malloc'd: the caller frees it when done with the chip). */
typedef struct wdr_cal_sim_margin {
    wdr_sim *sim;
    const wdr_board *board;
    const char *op_name;
    uint8_t *lut;
} wdr_cal_sim_margin;
int wdr_cal_sim_set_margin(void *ctx, double margin_v, double *done_v, double *added_s, char *err, int errlen);

#endif
