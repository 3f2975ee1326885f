/* The per-pixel physics: where M2 turns off on the ramp, then droop, source follower, read
 * noise and the column ADC. Hot path: no pow, no scan over the steps, one sqrt per stage. */
#include "sim_internal.h"
#include "sim_rng.h"
#include <math.h>
#include <string.h>

#define WALK_MAX 24 /* past this many single steps, a guess was poor: finish by bisection */

/* g <= 0: the pixel has crossed by node nd (its node voltage reached M2's turn-off level). */
static inline double crossing_g(const sim_node *nd, const sim_px *p)
{
    return nd->a + p->e0 - p->d * (nd->ch + p->d * nd->ch2) - p->ie * nd->t;
}

static inline int guess_node(const sim_ramp_table *tab, double amps)
{
    if (!(amps > 0))
        return tab->guess[0];
    float f = amps < 1e30 ? (float)amps : 1e30f;
    uint32_t u;
    memcpy(&u, &f, sizeof u);
    int64_t b = (int64_t)(u >> SIM_GUESS_SHIFT) - tab->guess_base;
    b = b < 0 ? 0 : (b >= tab->n_guess ? tab->n_guess - 1 : b);
    return tab->guess[b];
}

/* First node in [lo, n-1] crossed; n-1 when none is (the pixel holds the last value). */
static int bisect_first(const sim_ramp_table *tab, const sim_px *p, int lo)
{
    int hi = tab->n - 1;
    while (lo < hi) {
        int mid = (lo + hi) / 2;
        if (crossing_g(&tab->node[mid], p) <= 0)
            hi = mid;
        else
            lo = mid + 1;
    }
    return lo;
}

/* From a guess k, walk to the first crossed node: the condition is monotone in k. */
static int walk_first(const sim_ramp_table *tab, const sim_px *p, int k)
{
    const sim_node *nd = tab->node;
    if (crossing_g(&nd[k], p) <= 0) {
        for (int i = 0; k > 0 && crossing_g(&nd[k - 1], p) <= 0; i++, k--)
            if (i == WALK_MAX)
                return bisect_first(tab, p, 0);
        return k;
    }
    for (int i = 0; k < tab->n - 1; i++) {
        if (crossing_g(&nd[++k], p) <= 0)
            return k;
        if (i == WALK_MAX)
            return bisect_first(tab, p, k);
    }
    return k;
}

/* Guess twice: once from the current alone, then with this pixel's offsets folded into an
 * equivalent nominal current at the first guess. Usually lands within a step or two. */
static int search_first(const sim_ramp_table *tab, const sim_px *p)
{
    int k = guess_node(tab, p->ie);
    const sim_node *nd = &tab->node[k];
    if (nd->t > 0)
        k = guess_node(tab, p->ie - (p->e0 - p->d * (nd->ch + p->d * nd->ch2)) / nd->t);
    return walk_first(tab, p, k);
}

static double clampd(double x, double lo, double hi) { return x < lo ? lo : (x > hi ? hi : x); }

/* G level reached when V_ref jumps from pv->v to v_next with the node between the two steps'
 * turn-off levels. The crossing condition is linear in the charge terms between the nodes; for
 * a DAC step it is linear in v to far below a microvolt, for a coarse step solve it exactly. */
static double jump_level(const sim_ramp_table *tab, const sim_px *p, const sim_node *pv, double g_prev,
                         double g_start, double v_next)
{
    if (v_next - pv->v <= 4e-3)
        return pv->v + g_prev / (g_prev - g_start) * (v_next - pv->v);
    const wdr_pixel_dev *d = tab->dev;
    double v_n = wdr_pixel_voltage(d, tab->q0_nom + p->e0 - p->ie * pv->t) - p->d;
    /* G + V_T2(G) = v_n with s = sqrt(phi + G): s^2 + gamma s - (v_n + phi + gamma sqrt(phi) - vt0) = 0 */
    double r = v_n + d->phi2f + d->gamma * sqrt(d->phi2f) - d->vt0_m2;
    double sq = 0.5 * (-d->gamma + sqrt(d->gamma * d->gamma + 4.0 * (r > 0 ? r : 0)));
    return clampd(sq * sq - d->phi2f, pv->v, v_next);
}

/* Held G voltage and the time M2 turned off, for one pixel and frame. */
void sim_pixel_hold(const sim_ramp_table *tab, const sim_px *p, double *v_hold, double *t_cross)
{
    int k = search_first(tab, p);
    const sim_node *nd = &tab->node[k];
    double gk = crossing_g(nd, p);
    if (gk > 0) { /* never crossed: G followed the ramp to the end */
        *v_hold = nd->v;
        *t_cross = tab->t_int;
        return;
    }
    if (k == 0) {
        *v_hold = nd->v;
        *t_cross = 0;
        return;
    }
    const sim_node *pv = nd - 1;
    if (tab->continuous) {
        double gp = crossing_g(pv, p), f = gp / (gp - gk);
        *v_hold = pv->v + f * (nd->v - pv->v);
        *t_cross = pv->t + f * (nd->t - pv->t);
        return;
    }
    double g_start = gk + p->ie * (nd->t - pv->t); /* the condition as the step began */
    if (g_start <= 0) {
        /* the node was already below this step's turn-off level when V_ref jumped: M2 let G
         * rise only until it turned off, to h^-1(V_N) of this pixel */
        *v_hold = jump_level(tab, p, pv, crossing_g(pv, p), g_start, nd->v);
        *t_cross = pv->t;
        return;
    }
    /* within the step: M2 turned off when the collected charge reached the step's threshold */
    *v_hold = nd->v;
    *t_cross = p->ie > 0 ? clampd((gk + p->ie * nd->t) / p->ie, pv->t, nd->t) : nd->t;
}

/* M3 source follower, closed form of wdr_pixel_sf_out: with s = sqrt(phi + v_o),
 * s^2 + gamma s - (sf_k + v_g) = 0. Below cut-off the output sits at -phi as in pixel.c. */
double sim_sf_out(const wdr_sim *s, double sf_k, double v_g)
{
    double g = s->nom.gamma, disc = g * g + 4.0 * (sf_k + v_g);
    if (disc < g * g)
        return -s->nom.phi2f;
    double r = 0.5 * (-g + sqrt(disc));
    return r * r - s->nom.phi2f;
}

/* Column ADC: gain and offset, then codes over [v_lo, v_hi]; optional rounding and rails. */
double sim_adc(const wdr_board *b, double v, int quantise, int clip)
{
    double full = (double)((1u << b->adc_bits) - 1u);
    double x = (b->adc_gain * v + b->adc_offset_v - b->adc_lo_v) / (b->adc_hi_v - b->adc_lo_v) * full;
    if (quantise)
        x = floor(x + 0.5);
    return clip ? clampd(x, 0.0, full) : x;
}

/* One row's pixels through reset, integration and the compare: held voltages and times. */
void sim_expose_row(const wdr_sim *s, const sim_plan *plan, const sim_ramp_table *tab, int row, float *v_hold,
                    float *t_cross)
{
    const sim_fixed_view *f = &plan->fixed;
    uint64_t seed = s->frame_seed;
    for (int x = 0; x < s->width; x++) {
        long i = (long)row * s->width + x, j = i * f->stride;
        double amps = s->amps ? s->amps[i] : s->uniform_amps, c = f->cscale[j];
        if (plan->on[WDR_FX_DARK])
            amps += f->idark[j];
        sim_px p = {f->dq0[j], f->dvt2[j], amps / c};
        if (plan->on[WDR_FX_KTC])
            p.e0 += f->ktc_q[j] * sim_normal((uint32_t)sim_rng_u64(seed, SIM_RNG_KTC, (uint64_t)i));
        double v, t;
        sim_pixel_hold(tab, &p, &v, &t);
        if (plan->on[WDR_FX_SHOT] && p.ie * t > 0) {
            /* electrons collected until M2 turned off are Poisson (Gaussian at these counts) */
            double sigma = sqrt(SIM_Q_E * p.ie * t / c);
            p.e0 -= sigma * sim_normal((uint32_t)sim_rng_u64(seed, SIM_RNG_SHOT, (uint64_t)i));
            sim_pixel_hold(tab, &p, &v, &t);
        }
        v_hold[x] = (float)v;
        t_cross[x] = (float)t;
    }
}

/* One row read t_after seconds after integration: droop, source follower, read noise, ADC. */
void sim_read_row_codes(const wdr_sim *s, const sim_plan *plan, double t_int, int row, const float *v_hold,
                        const float *t_cross, double t_after, int quantise, float *codes)
{
    const sim_fixed_view *f = &plan->fixed;
    int clip = plan->on[WDR_FX_CLIPPING];
    quantise = quantise && plan->on[WDR_FX_ADC_QUANT];
    for (int x = 0; x < s->width; x++) {
        long i = (long)row * s->width + x;
        double vg = v_hold[x];
        if (plan->leak_v_per_s > 0)
            vg -= plan->leak_v_per_s * (t_int - t_cross[x] + t_after);
        double vo = sim_sf_out(s, f->sf_k[i * f->stride], vg);
        if (plan->on[WDR_FX_READ])
            vo += s->board.read_noise_v * sim_normal((uint32_t)sim_rng_u64(s->frame_seed, SIM_RNG_READ, (uint64_t)i));
        codes[x] = (float)sim_adc(&s->board, vo, quantise, clip);
    }
}
