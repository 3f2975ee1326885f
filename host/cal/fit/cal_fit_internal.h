/* Internal to the calibration fits (host/cal/fit/cal_*.c): what the split files share. Not for
 * callers outside host/cal; the public interface is cal_fit.h (the statistics': cal_stats.h). */
#ifndef WDR_CAL_FIT_INTERNAL_H
#define WDR_CAL_FIT_INTERNAL_H
#include "cal_fit.h"

/* Step that keeps a repaired falling curve strictly falling (codes). */
#define WDR_CAL_TIE_STEP 1e-5

/* cal_residual.c: what an LSQ or POLYMAP residual (rms, in ln x) is judged against. */
typedef struct wdr_cal_residual_limit {
    double sd_ln[WDR_CAL_MAX_LEVELS]; /* per level: its code's uncertainty over the nominal slope (ln x) */
    double noise_ln;                  /* rms of sd_ln over the levels */
    double misfit;                    /* the model's own residual on this chip, with room for a whole chip's tail */
    double limit;                     /* tie_sigmas * noise_ln + misfit: a larger residual is evidence */
} wdr_cal_residual_limit;
/* Measures the misfit by fitting a sample of the pixels not flagged in res->flags (w: 1 / slope per level). */
void wdr_cal_residual_limit_init(const wdr_cal_levels *lv, const wdr_cal_result *res, const double *med,
                                 const double *w, wdr_cal_residual_limit *lim);

/* cal_fit_paper.c: SIMPLE3/COMPLEX4 per pixel, the POLYMAP map and its variable */
double wdr_cal_poly_u(const wdr_cal_result *res, double y);
double wdr_cal_poly_eval(const double *c, int n, double u);
int wdr_cal_fit_paper_pixel(const wdr_cal_result *res, const double *u, const double *y, int n, const double *tol,
                            const double *w, double *par);
void wdr_cal_paper_weights(const wdr_cal_levels *lv, double *w);
/* resid (may be NULL) gets the rms residual in ln x; a residual, or a fall of the map, beyond lim->limit is UNFIT */
int wdr_cal_fit_polymap_pixel(const wdr_cal_result *res, const double *y, const double *target, const double *w, int n,
                              const wdr_cal_residual_limit *lim, double *par, double *resid);

/* cal_fit_lsq.c */
/* resid as for POLYMAP; a fall of the recovered current beyond lim->limit (in ln x) is REVERSED */
int wdr_cal_fit_lsq_pixel(const wdr_cal_result *res, const double *y, const double *u, int n, const double *med,
                          const wdr_cal_residual_limit *lim, double *theta, double *resid);
double wdr_cal_lsq_recover_u(const wdr_cal_result *res, const double *theta, double y);

/* cal_fit_spline.c */
int wdr_cal_falling_fit(const double *y, int n, const double *tol, const double *w, double *out);
int wdr_cal_fit_spline_pixel(const double *y, const double *med, int n, const double *tol, const double *w,
                             double *par);
double wdr_cal_spline_recover(const wdr_cal_result *res, const double *par, double y);

/* cal_nominal.c */
double wdr_nominal_invert_lx(const wdr_nominal *n, double z);
int wdr_nominal_build_inverse_table(wdr_nominal *n);

/* cal_fit_nominal.c */
int wdr_cal_is_curve_model(int model);
int wdr_cal_fit_nominal(const wdr_cal_levels *lv, wdr_cal_result *res, const double *med, char *err, int errlen);

#endif
