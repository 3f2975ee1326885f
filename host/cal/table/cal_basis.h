/* The BASIS table form's host side (internal to wdr_cal): a shared table of n basis functions of
 * the raw code, learnt from the array, and each pixel's n coefficients over it. */
#ifndef WDR_CAL_BASIS_H
#define WDR_CAL_BASIS_H
#include "cal_fit.h"

#define WDR_BASIS_SAMPLES 64 /* per pixel: the least-squares solver's row limit */

/* One pixel's exact map at currents log-spaced over the table's range: raw code y[k] should
 * give the nominal code t[k]; w[k] = 1 / |dy/d ln x| turns a code error into a contrast error. */
typedef struct wdr_map_samples {
    double y[WDR_BASIS_SAMPLES], t[WDR_BASIS_SAMPLES], w[WDR_BASIS_SAMPLES];
} wdr_map_samples;

/* m currents log-spaced over the nominal pixel's range [x_lo, x_hi] (cal_map_samples.c). */
void wdr_cal_map_log_spaced(const wdr_cal_result *res, double *xs, int m);
/* Fill s for pixel i (cal_map_samples.c, shared with the polynomial form's sampling). */
void wdr_cal_map_samples(const wdr_cal_result *res, long i, wdr_map_samples *s);
/* The same at any m currents xs: codes y, targets t, weights w (the shared table's dense fit). */
void wdr_cal_map_samples_at(const wdr_cal_result *res, long i, const double *xs, int m, double *y, double *t,
                            double *w);

/* The shared table: points x n float32, point-major, over raw codes lo + j * step. A SHIFTED
 * basis also moves each pixel's codes by a whole shift that lines its code at the anchor current
 * up with the sample's mean there, and weighs each sample current by u[k] (a minimax fit). */
typedef struct wdr_basis {
    int n, points;
    double lo, step;
    float *table;
    int shifted;
    double anchor_code, raw_max;
    double u[WDR_BASIS_SAMPLES];
    double mean_coeffs[WDR_CAL_MAX_COEFFS]; /* the array's mean map in these functions (an unfit pixel's) */
} wdr_basis;

/* Learn the basis from (a sample of) the array's good pixels: principal components of their
 * contrast-weighted maps, then alternating least squares (pixel coefficients, shared table) on
 * their samples; shifted: per-pixel code shifts and the minimax weights (the SHIFTED form).
 * @retval WDR_OK, WDR_E_NOMEM, WDR_E_NUMERIC (err says why: too few good pixels, no code range,
 * a degenerate basis) */
int wdr_cal_basis_learn(const wdr_cal_result *res, int n, int shifted, wdr_basis *b, char *err, int errlen);
void wdr_cal_basis_free(wdr_basis *b);

/* The table's two parts apart (wdr_cal_build_table is both): the shared basis the fit's form needs
 * (zeroed for a form without one), learnt once per calibration, and the per-pixel build over it.
 * The study times them apart: the learning is a fixed cost, the build a per-pixel one. */
int wdr_cal_table_basis(const wdr_cal_result *res, wdr_basis *basis, char *err, int errlen);
int wdr_cal_build_table_with(const wdr_cal_result *res, const wdr_basis *basis, uint32_t sensor_id, int operator_id,
                             uint8_t **out, size_t *out_len, char *err, int errlen);

/* The same span in other functions (cal_basis_condition.c): orthonormal over the table's points,
 * in codes, with a sample of the array's coefficients uncorrelated. A float fit gives the same
 * maps; the COMPACT form's int16 coefficients, scaled to each one's range over the array, need
 * not: the learnt functions nearly cancel where the pixels differ least, and their coefficients
 * then span 9-13 standard deviations. out->table is malloc'd (free it with wdr_cal_basis_free).
 * @retval WDR_OK, WDR_E_NOMEM, WDR_E_NUMERIC (too few good pixels, a degenerate span) */
int wdr_cal_basis_conditioned(const wdr_cal_result *res, const wdr_basis *in, wdr_basis *out);

/* The same functions held at their value past the codes the array's good pixels read at the
 * calibrated currents (cal_basis_reach.c): the table's pad, which only the smoothness penalty
 * holds, is where conditioned functions grow most (70x on sim-qvga Schlick), and the COMPACT
 * kernel's fixed-point shift is set by the largest value at any point. Maps change only at codes
 * no pixel read in calibration. out->table is malloc'd.
 * @retval WDR_OK, WDR_E_NOMEM, WDR_E_NUMERIC (no pixel reads a finite code) */
int wdr_cal_basis_held(const wdr_cal_result *res, const wdr_basis *in, wdr_basis *out);

/* What a COMPACT table's encoding loses: its kernel (wdr_correct_row_f32, as the board computes
 * it) against the same pixels' float maps over basis (wdr_cal_basis_coeffs, wdr_cal_basis_value),
 * the worst over the 64 log-spaced currents of the rms over sample rows' good pixels, in % of ln x
 * (code differences times the contrast weight, the slope floored at 1 code per ln). INFINITY when
 * the table does not parse. */
double wdr_cal_compact_departure(const wdr_cal_result *res, const wdr_basis *basis, const uint8_t *table, size_t len);

/* sum_k c[k] B_k(y): a pixel's float map over basis at raw code y (as the BASIS kernel reads it). */
double wdr_cal_basis_value(const wdr_basis *b, const double *c, double y);

/* A SHIFTED basis: the pixel's code shift (-64..63) from its samples, and its samples moved by it
 * as the kernel moves its codes (min(y + shift, raw_max)); 0 and unchanged otherwise. */
int wdr_cal_basis_shift(const wdr_basis *b, wdr_map_samples *s);

/* Pixel coefficients over the float32 table, as the kernel evaluates it (samples already
 * shifted). 1 when finite. */
int wdr_cal_basis_coeffs(const wdr_basis *b, const wdr_map_samples *s, double *c);

#endif
