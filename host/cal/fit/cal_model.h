/* Per-pixel calibration models of the paper (sec. 4) and the small dense linear algebra they need.
 * All in double, in scaled variables: currents as u = x / x_scale (x_scale about the middle of
 * the calibration currents) so six decades stay near 1, codes as they come (0..4095).
 * Every function reports failure with a reason code instead of producing NaN or Inf. */
#ifndef WDR_CAL_MODEL_H
#define WDR_CAL_MODEL_H

/* Why a pixel's fit or inversion failed (0 = fine). Stored in host reports, not in the table. */
enum wdr_fit_status {
    WDR_FIT_OK = 0,
    WDR_FIT_NONFINITE,      /* NaN or Inf in the input */
    WDR_FIT_FLAT,           /* two responses equal: zero slope, no information */
    WDR_FIT_REVERSED,       /* response not monotone in the expected direction */
    WDR_FIT_CLOSE_CURRENTS, /* two calibration currents (nearly) equal */
    WDR_FIT_ILL_COND,       /* the linear system is too ill-conditioned to trust */
    WDR_FIT_POLE,           /* the fitted curve has a pole inside the calibrated range */
    WDR_FIT_RESIDUAL,       /* fit residual far above what the model should give */
    WDR_FIT_DARK,           /* the dark reference is off the model: inverted, it puts the first light
                               level at or below zero current (a paper model's dark shift, eq. 20) */
    WDR_FIT_COUNT
};
const char *wdr_fit_status_name(int status);

/* ---- dense linear algebra (row-major, small n) ---- */

/* Solve A x = b (n x n, n <= 8) by LU with partial pivoting after equilibrating the columns;
 * A and b are overwritten. *rcond gets a cheap reciprocal condition estimate (smallest over
 * largest pivot of the equilibrated matrix). @retval WDR_FIT_OK, WDR_FIT_ILL_COND, WDR_FIT_NONFINITE */
int wdr_lu_solve(double *a, double *b, int n, double rcond_min, double *x, double *rcond);

/* Weighted least squares min |W (A c - y)| for an m x n A (n <= 8, m <= 64) by Householder QR
 * (no normal equations). w may be NULL (unit weights). A and y are overwritten.
 * @retval WDR_FIT_OK, WDR_FIT_ILL_COND (rank deficient), WDR_FIT_NONFINITE */
int wdr_lsq_solve(double *a, double *y, const double *w, int m, int n, double *c, double *rcond);

/* ---- stable quadratic root ---- */

/* The root of r t^2 + b t + c = 0 that tends to -c/b as r -> 0 (the physical branch of eq. 26),
 * computed without cancellation: q = -(b + sign(b) sqrt(disc)) / 2, root = c / q.
 * A negative discriminant is clamped to zero and *clamped set to 1.
 * @retval WDR_FIT_OK, WDR_FIT_FLAT (b = disc = 0: no unique root) */
int wdr_quadratic_root(double r, double b, double c, double *t, int *clamped);

/* ---- 3-parameter model, paper eq. 16: y = a - b(u+d) / (1 + c(u+d)) ---- */
typedef struct wdr_simple3 {
    double a, b, c, d; /* u = x / x_scale */
    double x_scale;
} wdr_simple3;

/* Closed form (eq. 19) through three points (u_i, y_i), u in scaled units, computed from
 * response differences and their ratio, not from the expanded determinants of eq. 19.
 * d is left at 0. @retval WDR_FIT_OK or a failure status */
int wdr_simple3_fit3(const double u[3], const double y[3], wdr_simple3 *m);

/* The paper's dark parameter (eq. 20), generalised to a dark-end reference at u0 >= 0:
 * a, b, c from the three currents (eq. 19), then d = u(y0) - u0 so that the inverse (eq. 26)
 * maps the dark reading to u0. (The Moebius family is closed under shifts of u: d is not
 * identifiable together with a, b, c, so it is an offset of the current scale, as in the paper.)
 * @retval WDR_FIT_OK or a failure status */
int wdr_simple3_fit_dark(const double u[3], const double y[3], double u0, double y0, wdr_simple3 *m);

/* Weighted least squares on the code residuals through n >= 3 points (u rising, y falling overall;
 * w the residuals' weights, one over each level's code sd, NULL for equal ones): with n = 3 the
 * closed form above (the paper's method); with more, Gauss-Newton from the closed form through
 * the first, a middle and the last point, each step solved by QR (never normal equations) and
 * halved until the residual falls, at most 50 steps. More levels average the rounding of each
 * level's code, which an exact fit through three passes on with a gain above 1 across six
 * decades. d is left at 0.
 * @retval WDR_FIT_OK, WDR_FIT_NONFINITE, WDR_FIT_CLOSE_CURRENTS, WDR_FIT_FLAT, WDR_FIT_REVERSED
 *         (the data or the fitted curve do not fall), WDR_FIT_POLE (a pole at or between the
 *         points), WDR_FIT_ILL_COND (n out of 3..64, or a rank-deficient step) */
int wdr_simple3_fit_lsq(const double *u, const double *y, const double *w, int n, wdr_simple3 *m);
/* The same with a dark-end reference (u0, y0) setting d as wdr_simple3_fit_dark does. */
int wdr_simple3_fit_lsq_dark(const double *u, const double *y, const double *w, int n, double u0, double y0,
                             wdr_simple3 *m);

double wdr_simple3_eval(const wdr_simple3 *m, double u);
/* Inverse (eq. 26, first line): u for response y. @retval WDR_FIT_OK, WDR_FIT_POLE (y beyond the
 * asymptote: *u gets the largest finite value u_cap) */
int wdr_simple3_invert(const wdr_simple3 *m, double y, double u_cap, double *u);
/* dy/du at u (negative for a falling response). */
double wdr_simple3_slope(const wdr_simple3 *m, double u);

/* ---- 4-parameter model, paper eq. 22-23: y = P + Q u - R u^2 - S y u ---- */
typedef struct wdr_complex4 {
    double p, q, r, s, d; /* u = x / x_scale */
    double x_scale;
    double rcond; /* condition estimate of the fit */
} wdr_complex4;

/* Solve eq. 24 for four points (pivoted LU on equilibrated columns, never an inverse).
 * @retval WDR_FIT_OK, WDR_FIT_ILL_COND, WDR_FIT_CLOSE_CURRENTS, WDR_FIT_NONFINITE */
int wdr_complex4_fit4(const double u[4], const double y[4], wdr_complex4 *m);
/* Same with a dark-end reference (u0, y0) giving d as for the 3-parameter model (eq. 21). */
int wdr_complex4_fit_dark(const double u[4], const double y[4], double u0, double y0, wdr_complex4 *m);
/* Weighted least squares on the code residuals through n >= 4 points, as wdr_simple3_fit_lsq:
 * n = 4 is wdr_complex4_fit4 (the paper's system); more start from the linearised least squares
 * of eq. 23 over all points (y (1 + S u) = P + Q u - R u^2, by QR) and take Gauss-Newton steps on
 * the residuals of y itself. The fitted curve must fall at every point.
 * @retval as wdr_simple3_fit_lsq */
int wdr_complex4_fit_lsq(const double *u, const double *y, const double *w, int n, wdr_complex4 *m);
int wdr_complex4_fit_lsq_dark(const double *u, const double *y, const double *w, int n, double u0, double y0,
                              wdr_complex4 *m);
double wdr_complex4_eval(const wdr_complex4 *m, double u);
/* Inverse (eq. 26, second line) on the physical branch, cancellation-free (roots C/q and q/R
 * with q = -(B + sign(B) sqrt(disc))/2); a negative discriminant is clamped to zero and reported
 * in *clamped. @retval WDR_FIT_OK, WDR_FIT_FLAT, WDR_FIT_POLE (*u = u_cap), WDR_FIT_NONFINITE */
int wdr_complex4_invert(const wdr_complex4 *m, double y, double u_cap, double *u, int *clamped);

#endif
