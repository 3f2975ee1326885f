/* Effect planning: estimate each effect's worst-case size for this scene and sensor, in ADC
 * LSB, by running the nominal pixel through the same physics with the effect pushed to its
 * worst case; `auto` skips the smallest ones while their summed estimate stays within the
 * tolerance, so the skipped effects together cannot move any pixel by more than it. Dark
 * current, shot and kTC noise depend strongly on the photocurrent: they are decided per band
 * of current (8 per octave), with what the global effects left of the tolerance. */
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

static double sf_gain(const wdr_sim *s, double v)
{
    return (sim_sf_out(s, s->sf_k_nom, v + 1e-3) - sim_sf_out(s, s->sf_k_nom, v - 1e-3)) / 2e-3;
}

static double nominal_cap(const wdr_pixel_dev *d, double v)
{
    return d->c_pd * pow((1.0 + d->c_pd_ref_v / d->pb) / (1.0 + v / d->pb), d->mj);
}

/* With a stepped ramp, a pixel whose node falls past a step's turn-off level during a DAC
 * jump holds G = h^-1(V_N): the node's own voltage. There a charge change dq moves G by up to
 * dq / C (the follower and the body effect only shrink it), however flat the response. */
static double jump_bound(const wdr_sim *s, int stepped, double v_hold, double dq)
{
    if (!stepped)
        return 0;
    double c = nominal_cap(&s->nom, wdr_pixel_turnoff_node(&s->nom, v_hold));
    return fabs(dq) / c * fabs(sf_gain(s, v_hold)) / lsb_volts(&s->board);
}

/* Worst output change over the probes when the nominal pixel gains the charge dq(I) (a
 * negative offset in the charge balance), on the continuous response and at a jump. */
typedef double (*charge_of)(const wdr_sim *s, double amps, double t_cross, int mismatch);

static double charge_effect(const wdr_sim *s, const sim_ramp_table *tab, const probe_set *ps, charge_of dq_of,
                            int mismatch, int stepped)
{
    double worst = 0;
    for (int k = 0; k < ps->n; k++) {
        double v, t;
        sim_px p = {0, 0, ps->amps[k]};
        sim_pixel_hold(tab, &p, 1, &v, &t);
        double dq = dq_of(s, ps->amps[k], t, mismatch), out0 = nominal_out(s, tab, ps->amps[k]);
        p.e0 = -dq;
        worst = fmax(worst, fabs(probe_out(s, tab, &p, s->sf_k_nom, 0) - out0));
        worst = fmax(worst, jump_bound(s, stepped, v, dq));
    }
    return worst;
}

/* dark current until the crossing, at its worst lognormal tail when mismatch spreads it */
static double dark_charge(const wdr_sim *s, double amps, double t, int mismatch)
{
    (void)amps;
    return s->board.dark_current_a * (mismatch ? exp(SIM_NORMAL_MAX * s->board.dark_sigma_ln) : 1.0) * t;
}

static double shot_charge(const wdr_sim *s, double amps, double t, int mismatch)
{
    (void)s, (void)mismatch;
    return SIM_NORMAL_MAX * sqrt(SIM_Q_E * amps * t);
}

static double ktc_charge(const wdr_sim *s, double amps, double t, int mismatch)
{
    (void)amps, (void)t, (void)mismatch;
    return SIM_NORMAL_MAX * s->ktc_q_nom;
}

static double est_dark(const wdr_sim *s, const sim_ramp_table *tab, const probe_set *ps, int mismatch)
{
    return charge_effect(s, tab, ps, dark_charge, mismatch, s->mode[WDR_FX_DAC_QUANT] != WDR_FX_OFF);
}

static double est_shot(const wdr_sim *s, const sim_ramp_table *tab, const probe_set *ps)
{
    return charge_effect(s, tab, ps, shot_charge, 0, s->mode[WDR_FX_DAC_QUANT] != WDR_FX_OFF);
}

static double est_ktc(const wdr_sim *s, const sim_ramp_table *tab, const probe_set *ps)
{
    return charge_effect(s, tab, ps, ktc_charge, 0, s->mode[WDR_FX_DAC_QUANT] != WDR_FX_OFF);
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

/* Droop of a pixel read in the first row: held from the start of the integration. */
static double est_leak_first_row(const wdr_sim *s, const sim_ramp_table *tab)
{
    return leak_rate(s) * tab->t_int * sf_gain(s, s->v_n0_nom * 0.5) / lsb_volts(&s->board);
}

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
    est[WDR_FX_KTC] = est_ktc(s, tab, &ps);
    est[WDR_FX_READ] = SIM_NORMAL_MAX * s->board.read_noise_v / lsb_volts(&s->board);
    est[WDR_FX_DAC_QUANT] = est_dac(s, &ps);
    est[WDR_FX_ADC_QUANT] = 0.5;
    est[WDR_FX_LEAKAGE] = est_leak(s, tab);
    double spread = 0;
    for (int k = 0; k < WDR_FX_CLIPPING; k++)
        spread += k == WDR_FX_ADC_QUANT ? 0 : est[k];
    est[WDR_FX_CLIPPING] = est_clip(s, tab, &ps, spread);
    /* a defective pixel can sit anywhere in the code range: its worst case is the full scale */
    est[WDR_FX_DEFECTS] = s->n_defects ? (double)((1u << s->board.adc_bits) - 1u) : 0;
}

static int is_noise(int fx) { return fx == WDR_FX_SHOT || fx == WDR_FX_KTC || fx == WDR_FX_READ; }

static const int banded_fx[3] = {WDR_FX_DARK, WDR_FX_SHOT, WDR_FX_KTC};
static const uint8_t banded_bit[3] = {SIM_BAND_DARK, SIM_BAND_SHOT, SIM_BAND_KTC};

static int is_banded(int fx) { return fx == WDR_FX_DARK || fx == WDR_FX_SHOT || fx == WDR_FX_KTC; }

static void report_fixed(wdr_sim *s, int fx, double est)
{
    wdr_fx_report *r = &s->report[fx];
    r->requested = s->mode[fx];
    r->ran = s->mode[fx] == WDR_FX_ON;
    r->estimate_lsb = est;
    snprintf(r->why, sizeof r->why, "%s by request", r->ran ? "on" : "off");
}

/* Skip auto effects, smallest first, while the skipped estimates add up to the tolerance;
 * returns what is left of it for the banded effects. */
static double decide_auto(wdr_sim *s, const double est[], sim_plan *plan)
{
    double budget = s->tolerance_lsb;
    for (;;) {
        int best = -1;
        for (int fx = 0; fx < WDR_FX_COUNT; fx++)
            if (s->mode[fx] == WDR_FX_AUTO && !is_banded(fx) && s->report[fx].why[0] == 0 &&
                (best < 0 || est[fx] < est[best]))
                best = fx;
        if (best < 0)
            return budget;
        wdr_fx_report *r = &s->report[best];
        r->requested = WDR_FX_AUTO;
        r->estimate_lsb = est[best];
        if (best == WDR_FX_DEFECTS) { /* nothing to estimate: either pixels were planted or not */
            r->ran = plan->on[best] = s->n_defects > 0;
            if (s->n_defects)
                snprintf(r->why, sizeof r->why, "auto: ran, %ld defective pixels planted", s->n_defects);
            else
                snprintf(r->why, sizeof r->why, "auto: skipped, no defective pixels planted");
        } else if (s->reference && is_noise(best)) {
            r->ran = plan->on[best] = 0;
            snprintf(r->why, sizeof r->why, "auto: skipped, the scene is a noiseless reference frame");
        } else if (est[best] <= budget) {
            budget -= est[best];
            r->ran = plan->on[best] = 0;
            snprintf(r->why, sizeof r->why, "auto: skipped, worst case %.3g LSB within the tolerance %.3g LSB",
                     est[best], s->tolerance_lsb);
        } else if (best == WDR_FX_LEAKAGE && est_leak_first_row(s, &s->continuous) > budget) {
            r->ran = plan->on[best] = 1;
            snprintf(r->why, sizeof r->why, "auto: ran, worst case %.3g LSB > %.3g LSB left; even row 0 droops "
                     "%.3g LSB", est[best], budget, est_leak_first_row(s, &s->continuous));
        } else {
            r->ran = plan->on[best] = 1;
            snprintf(r->why, sizeof r->why, "auto: ran, worst case %.3g LSB exceeds the %.3g LSB left of the "
                     "tolerance", est[best], budget);
        }
    }
}

/* ---- per-band decisions for dark current, shot and kTC noise ---- */

static void make_bands(const wdr_sim *s, sim_plan *plan)
{
    double lo = fmax(s->scene_i_min, 1e-18), hi = fmax(s->scene_i_max, lo);
    plan->band_base = sim_float_bits((float)lo) >> SIM_BAND_SHIFT;
    uint32_t top = sim_float_bits((float)hi) >> SIM_BAND_SHIFT;
    plan->n_bands = (int)(top - plan->band_base + 1);
    if (plan->n_bands > SIM_MAX_BANDS)
        plan->n_bands = SIM_MAX_BANDS; /* the last band then also holds everything above it */
}

/* Currents a band holds, clamped to the scene's: its edges and middle; the first band also
 * holds the unlit pixels, the last everything above its lower edge. */
static void band_probes(const wdr_sim *s, const sim_plan *plan, int b, probe_set *ps)
{
    double lo = sim_bits_float((plan->band_base + (uint32_t)b) << SIM_BAND_SHIFT);
    double hi = b == plan->n_bands - 1 ? s->scene_i_max
                                       : sim_bits_float((plan->band_base + (uint32_t)b + 1) << SIM_BAND_SHIFT);
    lo = fmax(lo, s->scene_i_min);
    hi = fmax(fmin(hi, s->scene_i_max), lo);
    ps->n = 0;
    ps->amps[ps->n++] = lo;
    ps->amps[ps->n++] = sqrt(fmax(lo, 1e-30) * fmax(hi, 1e-30));
    ps->amps[ps->n++] = hi;
    if (b == 0)
        ps->amps[ps->n++] = s->scene_i_min;
}

static void band_estimates(const wdr_sim *s, const sim_ramp_table *tab, const sim_plan *plan, int b, double est[3])
{
    probe_set ps;
    band_probes(s, plan, b, &ps);
    est[0] = est_dark(s, tab, &ps, plan->on[WDR_FX_MISMATCH]);
    est[1] = est_shot(s, tab, &ps);
    est[2] = est_ktc(s, tab, &ps);
}

static int auto_in_band(const wdr_sim *s, int k)
{
    return s->mode[banded_fx[k]] == WDR_FX_AUTO && !(s->reference && is_noise(banded_fx[k]));
}

/* In one band: the banded auto effects, smallest first, skipped while they fit the budget. */
static uint8_t band_decision(const wdr_sim *s, const double est[3], double budget)
{
    uint8_t mask = 0;
    int done[3] = {0, 0, 0};
    for (int k = 0; k < 3; k++) {
        done[k] = !auto_in_band(s, k);
        mask |= s->mode[banded_fx[k]] == WDR_FX_ON ? banded_bit[k] : 0;
    }
    for (;;) {
        int best = -1;
        for (int k = 0; k < 3; k++)
            if (!done[k] && (best < 0 || est[k] < est[best]))
                best = k;
        if (best < 0)
            return mask;
        done[best] = 1;
        if (est[best] <= budget)
            budget -= est[best];
        else
            mask |= banded_bit[best];
    }
}

typedef struct band_summary {
    int runs, first, last;
    int could_skip;             /* bands where it fitted the budget but runs anyway (dark current, see below) */
    double worst, worst_skipped;
    double least;               /* smallest band estimate: above the budget, no band can skip it */
} band_summary;

/* Why a charge effect cannot be skipped anywhere with a stepped ramp, however flat the response. */
static const char *band_reason(const wdr_sim *s, int fx)
{
    if (s->mode[WDR_FX_DAC_QUANT] == WDR_FX_OFF || fx == WDR_FX_DARK)
        return "";
    return "; DAC jumps pass charge noise undamped";
}

static void report_banded(wdr_sim *s, const sim_plan *plan, int k, const band_summary *bs, double budget)
{
    wdr_fx_report *r = &s->report[banded_fx[k]];
    r->requested = WDR_FX_AUTO;
    r->ran = bs->runs > 0;
    r->estimate_lsb = bs->worst;
    double lo = sim_bits_float((plan->band_base + (uint32_t)bs->first) << SIM_BAND_SHIFT);
    double hi = sim_bits_float((plan->band_base + (uint32_t)bs->last + 1) << SIM_BAND_SHIFT);
    if (s->reference && is_noise(banded_fx[k]))
        snprintf(r->why, sizeof r->why, "auto: skipped, the scene is a noiseless reference frame");
    else if (!bs->runs)
        snprintf(r->why, sizeof r->why, "auto: skipped, worst case %.3g LSB within the %.3g LSB left of the "
                 "tolerance", bs->worst, budget);
    else if (bs->could_skip > 0)
        snprintf(r->why, sizeof r->why, "auto: ran in all %d bands: %d could skip it (<= %.3g LSB), but a band "
                 "look-up per pixel costs more than it saves", plan->n_bands, bs->could_skip, bs->worst_skipped);
    else if (bs->runs == plan->n_bands)
        snprintf(r->why, sizeof r->why, "auto: ran in all %d bands, least worst case %.3g > %.3g LSB left%s",
                 plan->n_bands, bs->least, budget, band_reason(s, banded_fx[k]));
    else
        snprintf(r->why, sizeof r->why, "auto: ran in %d of %d current bands (%.2g..%.2g A), skipped where its "
                 "worst case is at most %.3g LSB", bs->runs, plan->n_bands, fmax(lo, s->scene_i_min),
                 fmin(hi, s->scene_i_max), bs->worst_skipped);
}

static int noise_varies(const sim_plan *plan)
{
    const unsigned noise = SIM_BAND_SHOT | SIM_BAND_KTC;
    for (int b = 1; b < plan->n_bands; b++)
        if ((plan->band_mask[b] & noise) != (plan->band_mask[0] & noise))
            return 1;
    return 0;
}

static void decide_bands(wdr_sim *s, const sim_ramp_table *tab, sim_plan *plan, double budget)
{
    band_summary bs[3] = {{0, -1, -1, 0, 0, 0, INFINITY}, {0, -1, -1, 0, 0, 0, INFINITY},
                          {0, -1, -1, 0, 0, 0, INFINITY}};
    int any_auto = auto_in_band(s, 0) || auto_in_band(s, 1) || auto_in_band(s, 2);
    make_bands(s, plan);
    if (!any_auto) /* nothing to decide per band: one band, no estimates */
        plan->n_bands = 1;
    for (int b = 0; b < plan->n_bands; b++) {
        double est[3] = {0, 0, 0};
        if (any_auto)
            band_estimates(s, tab, plan, b, est);
        plan->band_mask[b] = band_decision(s, est, budget);
        for (int k = 0; k < 3; k++) {
            int runs = (plan->band_mask[b] & banded_bit[k]) != 0;
            bs[k].worst = fmax(bs[k].worst, est[k]);
            bs[k].least = fmin(bs[k].least, est[k]);
            bs[k].worst_skipped = runs ? bs[k].worst_skipped : fmax(bs[k].worst_skipped, est[k]);
            bs[k].first = runs && bs[k].first < 0 ? b : bs[k].first;
            bs[k].last = runs ? b : bs[k].last;
            bs[k].runs += runs;
        }
    }
    if (bs[0].runs > 0 && bs[0].runs < plan->n_bands && !noise_varies(plan)) {
        /* Skipping dark current saves an addition; looking up each pixel's band costs more.
         * Only when a noise effect is skipped somewhere is banding worth it: else run it all over. */
        for (int b = 0; b < plan->n_bands; b++)
            plan->band_mask[b] |= SIM_BAND_DARK;
        bs[0].could_skip = plan->n_bands - bs[0].runs;
        bs[0].runs = plan->n_bands;
        bs[0].first = 0;
        bs[0].last = plan->n_bands - 1;
    }
    for (int b = 1; b < plan->n_bands; b++)
        plan->banded |= plan->band_mask[b] != plan->band_mask[0];
    for (int k = 0; k < 3; k++) {
        plan->on[banded_fx[k]] = bs[k].runs > 0;
        if (s->mode[banded_fx[k]] == WDR_FX_AUTO)
            report_banded(s, plan, k, &bs[k], budget);
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
    decide_bands(s, &s->continuous, plan, decide_auto(s, est, plan));
    plan->leak_v_per_s = plan->on[WDR_FX_LEAKAGE] ? leak_rate(s) : 0;
    sim_adc_line(&s->board, &plan->adc_scale, &plan->adc_zero);
    plan->adc_full = (double)((1u << s->board.adc_bits) - 1u);
    fill_fixed_view(s, plan);
}
