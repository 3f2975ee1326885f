/* What an LSQ or POLYMAP pixel's fit residual is judged against (issue 9: flag a pixel only on
 * evidence). Both models minimise an rms residual in ln x (relative current, the contrast error).
 * A healthy pixel's residual is at most its levels' noise seen through the response slope plus
 * what the model itself cannot follow on this chip; a fixed 5 % flagged 1,482 of 19,200 healthy
 * pixels (LSQ, 4 frames) and 846 (POLYMAP, converters on, noise off). The limit is therefore
 *     k sigma + misfit,
 * sigma the rms over the levels of their code uncertainty over the nominal slope, k = tie_sigmas,
 * misfit the model's own residual on a sample of this chip's pixels (noise taken out), with room
 * for the tail of a whole chip. */
#include "cal_design.h"
#include "cal_fit_internal.h"
#include <math.h>
#include <stdlib.h>

/* The misfit is measured on up to this many pixels spread over the array. */
#define MISFIT_SAMPLE 1024
#define MISFIT_QUANTILE 0.99
/* Over a whole VGA chip the worst healthy misfit is at most 2.1x the 99th percentile (measured,
 * analog, 307,200 pixels: LSQ Reinhard 0.0052 / 0.0025, Tumblin-Rushmeier 0.109 / 0.056;
 * POLYMAP <= 1.8x); twice that leaves room for the sample's own scatter. */
#define MISFIT_FACTOR 4.0

/* The levels are whole codes, or means of M whole codes: the ADC rounded them. */
static int levels_quantised(const wdr_cal_levels *lv)
{
    long np = (long)lv->width * lv->height, probe = np * lv->n < 4096 ? np * lv->n : 4096;
    double m = lv->m_avg > 1 ? lv->m_avg : 1;
    for (long i = 0; i < probe; i++) {
        double v = lv->frames[i] * m; /* a float mean of M codes times M: whole to ~1e-3 */
        if (fabs(v - nearbyint(v)) > 0.05)
            return 0;
    }
    return 1;
}

/* sd_ln[k]: the uncertainty of level k's code (measured temporal sd over sqrt(M), the ADC's
 * rounding when quantised and the DAC's step when known, in quadrature) over the nominal slope. */
static void level_sd_ln(const wdr_cal_levels *lv, const wdr_cal_result *res, double *sd_ln, double *rms)
{
    int quantised = levels_quantised(lv);
    double ss = 0;
    for (int k = 0; k < lv->n; k++) {
        double sd = wdr_cal_level_sd(lv, k), var = sd * sd;
        if (quantised)
            var += 1.0 / 12;
        if (res->cfg.step_codes > 0) {
            double step = res->cfg.design ? wdr_cal_design_dac_step_codes(res->cfg.design, fmax(lv->amps[k], 1e-18))
                                          : res->cfg.step_codes;
            var += step * step / 12;
        }
        sd_ln[k] = sqrt(var) / fmax(wdr_nominal_log_slope(&res->nominal, lv->amps[k]), 1e-9);
        ss += sd_ln[k] * sd_ln[k];
    }
    *rms = lv->n ? sqrt(ss / lv->n) : 0;
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

/* One pixel's fit with no limit: its residual (INFINITY when it cannot be fitted). */
static double sample_residual(const wdr_cal_levels *lv, const wdr_cal_result *res, long i, const double *med,
                              const double *w, const wdr_cal_residual_limit *open)
{
    long np = (long)lv->width * lv->height;
    double y[WDR_CAL_MAX_LEVELS], u[WDR_CAL_MAX_LEVELS], par[WDR_CAL_MAX_LEVELS + WDR_CAL_MAX_COEFFS], r = INFINITY;
    for (int k = 0; k < lv->n; k++)
        y[k] = lv->frames[(long)k * np + i], u[k] = lv->amps[k] / res->x_scale;
    if (res->model == WDR_MODEL_LSQ)
        wdr_cal_fit_lsq_pixel(res, y, u, lv->n, med, open, par, &r);
    else
        wdr_cal_fit_polymap_pixel(res, y, med, w, lv->n, open, par, &r);
    return r;
}

void wdr_cal_residual_limit_init(const wdr_cal_levels *lv, const wdr_cal_result *res, const double *med,
                                 const double *w, wdr_cal_residual_limit *lim)
{
    long np = (long)lv->width * lv->height, stride = np > MISFIT_SAMPLE ? np / MISFIT_SAMPLE : 1, m = 0;
    double misfit[MISFIT_SAMPLE + 1] = {0};
    level_sd_ln(lv, res, lim->sd_ln, &lim->noise_ln);
    /* noise left in a least-squares residual: n - p of the n levels' variance */
    double dof = lv->n > res->n_params ? (double)(lv->n - res->n_params) / lv->n : 0;
    wdr_cal_residual_limit open = *lim;
    open.limit = INFINITY;
    for (long i = stride / 2; i < np && m < MISFIT_SAMPLE; i += stride) {
        if (res->flags[i])
            continue;
        double r = sample_residual(lv, res, i, med, w, &open);
        if (isfinite(r))
            misfit[m++] = sqrt(fmax(r * r - dof * lim->noise_ln * lim->noise_ln, 0));
    }
    qsort(misfit, (size_t)m, sizeof misfit[0], cmp_double);
    double q = m ? misfit[(long)(MISFIT_QUANTILE * (m - 1))] : 0;
    /* max_residual caps what the chip's own misfit may excuse: a model that fits no pixel
     * does not make every residual acceptable */
    lim->misfit = fmin(MISFIT_FACTOR * q, res->cfg.max_residual);
    lim->limit = res->cfg.tie_sigmas * lim->noise_ln + lim->misfit;
}
