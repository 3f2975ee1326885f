/* The designed response: what a mismatch-free pixel of a board answers under an operator's ramp,
 * from the device equations (sim/pixel.h) and the operator's target g(I), with the hold node's
 * droop until a given row is read, through the source follower and the column ADC (unrounded).
 *
 * Calibration uses it where frames alone cannot tell: the slope of the response at the ends of
 * the calibrated range (a spline's end conditions), the slope that turns one code of rounding
 * into a contrast error (the quantisation floor), and the current a code stands for on the
 * operator's curve. It never uses a simulated chip's per-pixel parameters. */
#ifndef WDR_CAL_DESIGN_H
#define WDR_CAL_DESIGN_H
#include "cal_margin.h"
#include "board.h"
#include "operators.h"
#include "ramp.h"

#define WDR_CAL_DESIGN_START_NODES 8 /* the realised ramp's first nodes the design keeps */

typedef struct wdr_cal_design {
    wdr_board board;
    wdr_ideal_pixel px;
    wdr_operator op;
    double t_int_s;      /* integration time: the ramp's end (droop runs from the crossing to it) */
    double t_after_s;    /* time from the end of integration until the row is read */
    double leak_v_per_s; /* hold-node droop rate (0: no droop) */
    double dark_a;       /* the median dark current, added to the photocurrent */
    /* The start of the ramp the DAC realises (the board's LUT, its steps joined at their
     * midpoints as the simulator's continuous ramp joins them): its first code is held from
     * t = 0, so the brightest currents cross a ramp shallower than the ideal one. Crossings
     * before start_t[n_start - 1] use these nodes, later ones the ideal ramp (0: none). */
    int n_start;
    double start_t[WDR_CAL_DESIGN_START_NODES], start_v[WDR_CAL_DESIGN_START_NODES];
} wdr_cal_design;

/* The design of board b under operator op_name (default parameters and the board's default scene
 * statistics, as `wdrctl lut build` without an image). t_int_s: the LUT's integration time
 * (0: the crossing time of the board's dimmest current); t_after_s: when the row is read
 * (the middle row: height / 2 * row_time); with_effects: 0 leaves the droop, the dark current
 * and the realised ramp's start out (the ideal pixel on the ideal ramp).
 * @retval WDR_OK, or the operator's or the board's ramp's error (err names it) */
int wdr_cal_design_init(wdr_cal_design *d, const wdr_board *b, const char *op_name, double t_int_s, double t_after_s,
                        int with_effects, char *err, int errlen);

/* Unrounded ADC code of the designed pixel at photocurrent x (A). */
double wdr_cal_design_code(const wdr_cal_design *d, double x);

/* d code / d ln x at x (codes per unit of ln x; negative: brighter light, lower code). */
double wdr_cal_design_log_slope(const wdr_cal_design *d, double x);

/* One DAC step at the level current x holds, in ADC codes (through the source follower). */
double wdr_cal_design_dac_step_codes(const wdr_cal_design *d, double x);

/* Ratio of the slope at x0 to the secant from x0 to x1: the shape of the response at an end of a
 * set of knots, independent of the pixel's own gain. */
double wdr_cal_design_end_ratio(const wdr_cal_design *d, double x0, double x1);

/* The calibration margin probe's request for this design (cal_margin.h: the follower's gain at
 * the dark end, the DAC step): levels dim_a and bright_a, frames each. Here, in fit/, because the
 * margin itself is acquisition (acquire/cal_margin.c) and may not reach up into the design. */
void wdr_cal_margin_req_for(const wdr_cal_design *d, double dim_a, double bright_a, int frames,
                            wdr_cal_margin_req *req);

#endif
