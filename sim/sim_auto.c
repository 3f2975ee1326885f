/* Effect planning: estimate each effect's worst-case size for this scene and sensor, in ADC
 * LSB, by running the nominal pixel through the same physics with the effect pushed to its
 * worst case; `auto` skips the smallest ones while their summed estimate stays within the
 * tolerance, so the skipped effects together cannot move any pixel by more than it. */
#include "sim_internal.h"
#include "sim_rng.h"
#include <math.h>
#include <stdio.h>
#include <string.h>

#define N_PROBE 33 /* photocurrents probed across the scene's range */

typedef struct probe_set {
    int n;
    double amps[N_PROBE];
} probe_set;

static void make_probes(const wdr_sim *s, probe_set *ps)
{
    double lo = fmax(s->scene_i_min, 1e-18), hi = fmax(s->scene_i_max, lo);
    ps->n = hi > lo * (1 + 1e-9) ? N_PROBE : 1;
    for (int k = 0; k < ps->n; k++)
        ps->amps[k] = ps->n == 1 ? lo : lo * pow(hi / lo, (double)k / (ps->n - 1));
}

static double lsb_volts(const wdr_board *b)
{
    return (b->adc_hi_v - b->adc_lo_v) / ((double)((1u << b->adc_bits) - 1u) * b->adc_gain);
}

/* Output of one pixel in unrounded, unclipped ADC codes. */
static double probe_out(const wdr_sim *s, const sim_ramp_table *tab, const sim_px *p, double sf_k, double droop)
{
    double v, t;
    sim_pixel_hold(tab, p, 0, &v, &t);
    return sim_adc(&s->board, sim_sf_out(s, sf_k, v - droop), 0, 0);
}

static double nominal_out(const wdr_sim *s, const sim_ramp_table *tab, double amps)
{
    sim_px p = {0, 0, amps};
    return probe_out(s, tab, &p, s->sf_k_nom, 0);
}

/* Largest output change over the probes when the nominal pixel gets offsets (e0, d, c). */
static double worst_shift(const wdr_sim *s, const sim_ramp_table *tab, const probe_set *ps, double e0, double d,
                          double c, double d_sf_k)
{
    double worst = 0;
    for (int k = 0; k < ps->n; k++) {
        sim_px p = {e0, d, ps->amps[k] / c};
        double shift = fabs(probe_out(s, tab, &p, s->sf_k_nom + d_sf_k, 0) - nominal_out(s, tab, ps->amps[k]));
        worst = fmax(worst, shift);
    }
    return worst;
}

static double est_mismatch(const wdr_sim *s, const sim_ramp_table *tab, const probe_set *ps)
{
    const wdr_board *b = &s->board;
    double z = SIM_NORMAL_MAX, sig[3];
    const wdr_mos *m[3] = {&b->m1, &b->m2, &b->m3};
    for (int k = 0; k < 3; k++)
        sig[k] = z * 1e-3 * b->avt_mv_um / sqrt(m[k]->w_um * m[k]->l_um);
    double e0 = sim_reset_dq0(s, sig[0]);
    double beta = z * 0.01 * b->abeta_pct_um / sqrt(b->m3.w_um * b->m3.l_um);
    double d_sf = sig[2] + sqrt(2 * s->nom.sf_bias / s->nom.beta3) * (1 / sqrt(fmax(1 - beta, 0.1)) - 1);
    double c = 1 + z * 0.01 * b->c_pd_sigma_pct;
    return worst_shift(s, tab, ps, e0, 0, 1, 0) + worst_shift(s, tab, ps, 0, sig[1], 1, 0) +
           worst_shift(s, tab, ps, 0, 0, c, 0) + fabs(worst_shift(s, tab, ps, 0, 0, 1, -d_sf));
}

static double est_dark(const wdr_sim *s, const sim_ramp_table *tab, const probe_set *ps, int mismatch)
{
    double dark = s->board.dark_current_a * (mismatch ? exp(SIM_NORMAL_MAX * s->board.dark_sigma_ln) : 1.0);
    double worst = 0;
    for (int k = 0; k < ps->n; k++) {
        sim_px p = {0, 0, ps->amps[k] + dark};
        worst = fmax(worst, fabs(probe_out(s, tab, &p, s->sf_k_nom, 0) - nominal_out(s, tab, ps->amps[k])));
    }
    return worst;
}

static double est_shot(const wdr_sim *s, const sim_ramp_table *tab, const probe_set *ps)
{
    double worst = 0;
    for (int k = 0; k < ps->n; k++) {
        double v, t;
        sim_px p = {0, 0, ps->amps[k]};
        sim_pixel_hold(tab, &p, 1, &v, &t);
        p.e0 = SIM_NORMAL_MAX * sqrt(SIM_Q_E * ps->amps[k] * t);
        worst = fmax(worst, fabs(probe_out(s, tab, &p, s->sf_k_nom, 0) - nominal_out(s, tab, ps->amps[k])));
    }
    return worst;
}

static double sf_gain(const wdr_sim *s, double v)
{
    return (sim_sf_out(s, s->sf_k_nom, v + 1e-3) - sim_sf_out(s, s->sf_k_nom, v - 1e-3)) / 2e-3;
}

/* Largest DAC step inside the probed range, seen through the source follower. */
static double est_dac(const wdr_sim *s, const probe_set *ps)
{
    const sim_ramp_table *st = &s->stepped;
    double v_lo = INFINITY, v_hi = -INFINITY, step = 0, v, t;
    for (int k = 0; k < ps->n; k++) {
        sim_px p = {0, 0, ps->amps[k]};
        sim_pixel_hold(st, &p, 0, &v, &t);
        v_lo = fmin(v_lo, v);
        v_hi = fmax(v_hi, v);
    }
    for (int k = 1; k < st->n; k++)
        if (st->node[k].v >= v_lo && st->node[k - 1].v <= v_hi)
            step = fmax(step, st->node[k].v - st->node[k - 1].v);
    return step * sf_gain(s, 0.5 * (v_lo + v_hi)) / lsb_volts(&s->board);
}

static double leak_rate(const wdr_sim *s) { return s->board.hold_leak_a / s->board.c_hold_f; }

static double est_leak(const wdr_sim *s, const sim_ramp_table *tab)
{
    double t = tab->t_int + (s->height - 1) * s->board.row_time_s;
    return leak_rate(s) * t * sf_gain(s, s->v_n0_nom * 0.5) / lsb_volts(&s->board);
}

/* How far past a rail the scene's outputs may reach (0: no pixel can clip). */
static double est_clip(const wdr_sim *s, const sim_ramp_table *tab, const probe_set *ps, double spread)
{
    double full = (double)((1u << s->board.adc_bits) - 1u), worst = 0;
    for (int k = 0; k < ps->n; k++) {
        double out = nominal_out(s, tab, ps->amps[k]);
        worst = fmax(worst, fmax(out + spread - full, -(out - spread)));
    }
    return worst;
}

static void estimate_all(const wdr_sim *s, const sim_ramp_table *tab, const sim_plan *plan, double est[])
{
    probe_set ps;
    make_probes(s, &ps);
    est[WDR_FX_MISMATCH] = est_mismatch(s, tab, &ps);
    est[WDR_FX_DARK] = est_dark(s, tab, &ps, plan->on[WDR_FX_MISMATCH]);
    est[WDR_FX_SHOT] = est_shot(s, tab, &ps);
    est[WDR_FX_KTC] = worst_shift(s, tab, &ps, SIM_NORMAL_MAX * s->ktc_q_nom, 0, 1, 0);
    est[WDR_FX_READ] = SIM_NORMAL_MAX * s->board.read_noise_v / lsb_volts(&s->board);
    est[WDR_FX_DAC_QUANT] = est_dac(s, &ps);
    est[WDR_FX_ADC_QUANT] = 0.5;
    est[WDR_FX_LEAKAGE] = est_leak(s, tab);
    double spread = 0;
    for (int k = 0; k < WDR_FX_CLIPPING; k++)
        spread += k == WDR_FX_ADC_QUANT ? 0 : est[k];
    est[WDR_FX_CLIPPING] = est_clip(s, tab, &ps, spread);
}

static int is_noise(int fx) { return fx == WDR_FX_SHOT || fx == WDR_FX_KTC || fx == WDR_FX_READ; }

static void report_fixed(wdr_sim *s, int fx, double est)
{
    wdr_fx_report *r = &s->report[fx];
    r->requested = s->mode[fx];
    r->ran = s->mode[fx] == WDR_FX_ON;
    r->estimate_lsb = est;
    snprintf(r->why, sizeof r->why, "%s by request", r->ran ? "on" : "off");
}

/* Skip auto effects, smallest first, while the skipped estimates add up to the tolerance. */
static void decide_auto(wdr_sim *s, const double est[], sim_plan *plan)
{
    double budget = s->tolerance_lsb;
    for (;;) {
        int best = -1;
        for (int fx = 0; fx < WDR_FX_COUNT; fx++)
            if (s->mode[fx] == WDR_FX_AUTO && s->report[fx].why[0] == 0 && (best < 0 || est[fx] < est[best]))
                best = fx;
        if (best < 0)
            return;
        wdr_fx_report *r = &s->report[best];
        r->requested = WDR_FX_AUTO;
        r->estimate_lsb = est[best];
        if (s->reference && is_noise(best)) {
            r->ran = plan->on[best] = 0;
            snprintf(r->why, sizeof r->why, "auto: skipped, the scene is a noiseless reference frame");
        } else if (est[best] <= budget) {
            budget -= est[best];
            r->ran = plan->on[best] = 0;
            snprintf(r->why, sizeof r->why, "auto: skipped, worst case %.3g LSB within the tolerance %.3g LSB",
                     est[best], s->tolerance_lsb);
        } else {
            r->ran = plan->on[best] = 1;
            snprintf(r->why, sizeof r->why, "auto: ran, worst case %.3g LSB exceeds the %.3g LSB left of the "
                     "tolerance", est[best], budget);
        }
    }
}

static void fill_fixed_view(const wdr_sim *s, sim_plan *plan)
{
    sim_fixed_view *f = &plan->fixed;
    const float *nom = s->nominal_fx;
    if (plan->on[WDR_FX_MISMATCH])
        *f = (sim_fixed_view){s->fx.dq0, s->fx.dvt2, s->fx.cinv, s->fx.idark, s->fx.sf_k, s->fx.ktc_q, 1};
    else
        *f = (sim_fixed_view){nom, nom + 1, nom + 2, nom + 3, nom + 4, nom + 5, 0};
}

void sim_plan_effects(wdr_sim *s, sim_plan *plan)
{
    double est[WDR_FX_COUNT];
    memset(plan, 0, sizeof *plan);
    memset(s->report, 0, sizeof s->report);
    /* mismatch decides which dark-current spread the estimate assumes: settle it first */
    plan->on[WDR_FX_MISMATCH] = s->mode[WDR_FX_MISMATCH] != WDR_FX_OFF;
    estimate_all(s, &s->continuous, plan, est);
    for (int fx = 0; fx < WDR_FX_COUNT; fx++)
        if (s->mode[fx] != WDR_FX_AUTO) {
            report_fixed(s, fx, est[fx]);
            plan->on[fx] = s->mode[fx] == WDR_FX_ON;
        }
    decide_auto(s, est, plan);
    plan->leak_v_per_s = plan->on[WDR_FX_LEAKAGE] ? leak_rate(s) : 0;
    sim_adc_line(&s->board, &plan->adc_scale, &plan->adc_zero);
    plan->adc_full = (double)((1u << s->board.adc_bits) - 1u);
    fill_fixed_view(s, plan);
}
