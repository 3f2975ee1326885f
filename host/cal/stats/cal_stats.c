/* Noise-aware statistics: the temporal noise a calibration measured on its own frames decides
 * what counts as a tie, a reversal or a spacing between levels (never a fixed code count). */
#include "cal_stats.h"
#include "wdr_err.h"
#include <math.h>
#include <string.h>

double wdr_cal_level_sd(const wdr_cal_levels *lv, int k)
{
    if (lv->m_avg < 1 || k < 0 || k >= lv->n)
        return 0;
    double s = lv->amps[k] > 0 ? lv->noise[k] : lv->dark_noise;
    return s / sqrt((double)lv->m_avg);
}

double wdr_cal_tie_tolerance(const wdr_cal_levels *lv, const wdr_cal_config *cfg, int k)
{
    int j = k < 1 ? 1 : k;
    double a = wdr_cal_level_sd(lv, j - 1), b = wdr_cal_level_sd(lv, j);
    /* sd of the difference of two independent M-frame means: sigma sqrt(2/M) for equal sigmas */
    return cfg->tie_codes + cfg->tie_sigmas * sqrt(a * a + b * b);
}

/* Pool adjacent violators, falling: blocks of levels are merged while a later block's mean
 * lies above an earlier one's; each block then takes its weighted mean. */
void wdr_cal_isotonic_falling(const double *y, const double *w, int n, double *out)
{
    double mean[WDR_PCHIP_MAX], weight[WDR_PCHIP_MAX];
    int len[WDR_PCHIP_MAX], nb = 0;
    for (int k = 0; k < n; k++) {
        mean[nb] = y[k], weight[nb] = w[k], len[nb] = 1;
        nb++;
        while (nb > 1 && mean[nb - 1] > mean[nb - 2]) {
            double wt = weight[nb - 2] + weight[nb - 1];
            mean[nb - 2] = (mean[nb - 2] * weight[nb - 2] + mean[nb - 1] * weight[nb - 1]) / wt;
            weight[nb - 2] = wt;
            len[nb - 2] += len[nb - 1];
            nb--;
        }
    }
    for (int b = 0, k = 0; b < nb; b++)
        for (int j = 0; j < len[b]; j++)
            out[k++] = mean[b];
}

void wdr_cal_level_tolerances(const wdr_cal_levels *lv, const wdr_cal_config *cfg, double *tol, double *w)
{
    for (int k = 0; k < lv->n; k++) {
        double sd = wdr_cal_level_sd(lv, k);
        tol[k] = wdr_cal_tie_tolerance(lv, cfg, k);
        w[k] = sd > 0 ? 1 / (sd * sd) : 1;
    }
}

/* |dy/d ln x| of the array median at grid level k, from its neighbours (one side at the ends). */
static double median_log_slope(const double *med, const double *amps, int n, int k)
{
    int a = k > 0 ? k - 1 : k, b = k + 1 < n ? k + 1 : k;
    if (a == b || !(amps[a] > 0))
        return 0;
    return fabs(med[b] - med[a]) / log(amps[b] / amps[a]);
}

int wdr_cal_frames_for(const wdr_cal_levels *probe, const double *med, double lo, double hi, double lsb,
                       double target_pct, int max_frames, wdr_cal_frames_choice *out)
{
    memset(out, 0, sizeof *out);
    out->frames = 2;
    out->target_pct = target_pct;
    if (probe->m_avg < 2)
        return WDR_E_INVAL;
    for (int k = 0; k < probe->n; k++) {
        if (probe->amps[k] < lo * (1 - 1e-9) || probe->amps[k] > hi * (1 + 1e-9))
            continue;
        double slope = median_log_slope(med, probe->amps, probe->n, k), sigma = probe->noise[k];
        /* the calibration's temporal error at this level: sigma / sqrt(M) codes. Wanted: below the
         * target contrast (target x slope codes), and never finer than half the quantisation
         * floor lsb / sqrt(12), which averaging cannot beat anyway where the noise dithers less */
        double want = fmax(target_pct / 100 * slope, 0.5 * lsb / sqrt(12.0));
        if (!(want > 0))
            continue;
        double m = ceil(sigma * sigma / (want * want));
        if (m > out->needed || !out->at_amps) {
            if (m > out->needed)
                out->needed = (int)fmin(m, 1e6);
            out->at_amps = probe->amps[k], out->sigma_codes = sigma, out->slope = slope, out->want_codes = want;
        }
    }
    out->frames = out->needed < 2 ? 2 : out->needed > max_frames ? max_frames : out->needed;
    out->capped = out->needed > max_frames;
    return WDR_OK;
}
