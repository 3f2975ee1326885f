/* The per-pixel physics: where M2 turns off on the ramp, then droop, source follower, read
 * noise and the column ADC. Hot path: no pow, no scan over the steps, one sqrt per stage. */
#include "sim_internal.h"
#include "sim_rng.h"
#include <math.h>
#include <string.h>

#define WALK_MAX 24            /* past this many single steps, a guess was poor: finish by bisection */
#define JUMP_LINEAR_MAX_V 4e-3 /* below this DAC step, the jump level is linear in the charge terms */

/* g <= 0: the pixel has crossed by node nd (its node voltage reached M2's turn-off level). */
static inline double crossing_g(const sim_node *nd, const sim_px *p)
{
    return nd->a + p->e0 - p->d * (nd->ch + p->d * nd->ch2) - p->ie * nd->t;
}

/* The float bits of a positive current rise with it: their top bits are a cheap log2. */
static inline int guess_node(const sim_ramp_table *tab, double amps)
{
    float f = (float)amps; /* currents are at most 1 A (checked where they come in) */
    int32_t u;             /* as a signed integer, a negative current sorts below every positive one */
    memcpy(&u, &f, sizeof u);
    int32_t b = (u >> SIM_GUESS_SHIFT) - (int32_t)tab->guess_base;
    b = b < 0 ? 0 : b;
    b = b >= tab->n_guess ? tab->n_guess - 1 : b;
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

/* Second guess: this pixel's offsets folded into an equivalent nominal current at the first
 * guess k. Usually lands within a step of the answer. */
static inline int refine_guess(const sim_ramp_table *tab, const sim_px *p, int k)
{
    const sim_node *nd = &tab->node[k];
    return guess_node(tab, p->ie - (p->e0 - p->d * (nd->ch + p->d * nd->ch2)) * nd->inv_t);
}

/* Where the search ended: the first crossed node k (or the last node, not crossed), the
 * condition there and at k-1 (+1 when k = 0), so the hold needs no re-evaluation. */
typedef struct sim_cross {
    int k;
    double g_k, g_prev;
} sim_cross;

static inline sim_cross cross_at(const sim_ramp_table *tab, const sim_px *p, int k)
{
    return (sim_cross){k, crossing_g(&tab->node[k], p), k > 0 ? crossing_g(&tab->node[k - 1], p) : 1.0};
}

/* First crossed node, from a guess k. The usual cases are tested without a loop: the answer
 * is k, or k-1 (the second guess runs one step high when the bucket edge falls mid-step). */
static inline sim_cross settle(const sim_ramp_table *tab, const sim_px *p, int k)
{
    double g0 = crossing_g(&tab->node[k], p), g1 = k > 0 ? crossing_g(&tab->node[k - 1], p) : 1.0;
    if (__builtin_expect(g0 <= 0 && g1 > 0, 1))
        return (sim_cross){k, g0, g1};
    if (g1 <= 0) {
        double g2 = k > 1 ? crossing_g(&tab->node[k - 2], p) : 1.0;
        if (g2 > 0)
            return (sim_cross){k - 1, g1, g2};
    }
    return cross_at(tab, p, walk_first(tab, p, k));
}

static double clampd(double x, double lo, double hi) { return x < lo ? lo : (x > hi ? hi : x); }

/* floor(x + 0.5) without a libm call on the usual in-range codes */
static inline double round_half_up(double x)
{
    return x >= 0 && x < 2e9 ? (double)(int64_t)(x + 0.5) : floor(x + 0.5);
}

/* G level reached when V_ref jumps from pv->v to v_next with the node between the two steps'
 * turn-off levels. The crossing condition is linear in the charge terms between the nodes; for
 * a DAC step it is linear in v to far below a microvolt, for a coarse step solve it exactly. */
static double jump_level(const sim_ramp_table *tab, const sim_px *p, const sim_node *pv, double g_prev,
                         double g_start, double v_next)
{
    if (v_next - pv->v <= JUMP_LINEAR_MAX_V)
        return pv->v + g_prev / (g_prev - g_start) * (v_next - pv->v);
    const wdr_pixel_dev *d = tab->dev;
    double v_n = wdr_pixel_voltage(d, tab->q0_nom + p->e0 - p->ie * pv->t) - p->d;
    /* G + V_T2(G) = v_n with s = sqrt(phi + G): s^2 + gamma s - (v_n + phi + gamma sqrt(phi) - vt0) = 0 */
    double r = v_n + d->phi2f + d->gamma * sqrt(d->phi2f) - d->vt0_m2;
    double sq = 0.5 * (-d->gamma + sqrt(d->gamma * d->gamma + 4.0 * (r > 0 ? r : 0)));
    return clampd(sq * sq - d->phi2f, pv->v, v_next);
}

/* Held G voltage and the time M2 turned off, for one pixel and frame. */
static inline void hold_at(const sim_ramp_table *tab, const sim_px *p, sim_cross c, int need_t, double *v_hold,
                           double *t_cross)
{
    int k = c.k;
    const sim_node *nd = &tab->node[k];
    double gk = c.g_k, gp = c.g_prev;
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
        double f = gp / (gp - gk);
        *v_hold = pv->v + f * (nd->v - pv->v);
        *t_cross = pv->t + f * (nd->t - pv->t);
        return;
    }
    double g_start = gk + p->ie * (nd->t - pv->t); /* the condition as the step began */
    double dv = nd->v - pv->v;
    if (dv > JUMP_LINEAR_MAX_V && g_start <= 0) {
        *v_hold = jump_level(tab, p, pv, gp, g_start, nd->v);
        *t_cross = pv->t;
        return;
    }
    /* Either the node was already below this step's turn-off level when V_ref jumped (M2 let
     * G rise only until it turned off, between the two codes), or M2 turned off within the
     * step when the collected charge reached its threshold. Chosen without a branch: which
     * one happens is as good as random from pixel to pixel. */
    int jumped = g_start <= 0;
    double f = gp / (gp - (g_start < 0 ? g_start : 0.0)); /* gp > 0: node k-1 was not crossed */
    double t_within = need_t && p->ie > 0 ? clampd((gk + p->ie * nd->t) / p->ie, pv->t, nd->t) : nd->t;
    *v_hold = jumped ? pv->v + f * dv : nd->v;
    *t_cross = jumped ? pv->t : t_within;
}

void sim_pixel_hold(const sim_ramp_table *tab, const sim_px *p, int need_t, double *v_hold, double *t_cross)
{
    int k = refine_guess(tab, p, guess_node(tab, p->ie));
    hold_at(tab, p, settle(tab, p, k), need_t, v_hold, t_cross);
}

/* M3 source follower, closed form of wdr_pixel_sf_out: with s = sqrt(phi + v_o),
 * s^2 + gamma s - (sf_k + v_g) = 0. Below cut-off the output sits at -phi as in pixel.c. */
double sim_sf_out(const wdr_sim *s, double sf_k, double v_g)
{
    double g = s->nom.gamma, disc = g * g + 4.0 * (sf_k + v_g);
    disc = disc > g * g ? disc : g * g; /* below cut-off: r = 0, the output sits at -phi */
    double r = 0.5 * (sqrt(disc) - g);
    return r * r - s->nom.phi2f;
}

/* The ADC as a line in the source-follower voltage: code = scale * v + zero. */
void sim_adc_line(const wdr_board *b, double *scale, double *zero)
{
    double full = (double)((1u << b->adc_bits) - 1u), span = b->adc_hi_v - b->adc_lo_v;
    *scale = b->adc_gain / span * full;
    *zero = (b->adc_offset_v - b->adc_lo_v) / span * full;
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

/* A pixel's inputs for this frame: fixed pattern, current and reset noise. */
static inline sim_px pixel_inputs(const wdr_sim *s, const sim_plan *plan, long i, unsigned *band_mask)
{
    const sim_fixed_view *f = &plan->fixed;
    long j = i * f->stride;
    double amps = s->amps ? s->amps[i] : s->uniform_amps;
    unsigned mask = *band_mask = plan->band_mask[plan->banded ? sim_band_of(plan, amps) : 0];
    if (mask & SIM_BAND_DARK)
        amps += f->idark[j];
    sim_px p = {f->dq0[j], f->dvt2[j], amps * f->cinv[j]};
    if (mask & SIM_BAND_KTC)
        p.e0 += f->ktc_q[j] * sim_normal((uint32_t)sim_rng_u64(s->frame_seed, SIM_RNG_KTC, (uint64_t)i));
    return p;
}

/* Electrons collected until M2 turned off are Poisson (Gaussian at these counts): move the
 * charge balance by one draw and let the crossing settle again from where it was. */
static inline sim_cross add_shot_noise(const wdr_sim *s, const sim_plan *plan, const sim_ramp_table *tab, long i,
                                       sim_px *p, int k, double t)
{
    double sigma = sqrt(SIM_Q_E * p->ie * t * plan->fixed.cinv[i * plan->fixed.stride]);
    p->e0 -= sigma * sim_normal((uint32_t)sim_rng_u64(s->frame_seed, SIM_RNG_SHOT, (uint64_t)i));
    return settle(tab, p, k);
}

#define BATCH 32

/* Stages one and two for a batch of pixels: inputs and the two guesses. Stage by stage, the
 * table look-ups of neighbouring pixels overlap instead of waiting on each other. */
static inline void batch_guess(const wdr_sim *s, const sim_plan *plan, const sim_ramp_table *tab, long i0, int n,
                               sim_px *p, int *k, unsigned *mask)
{
    int offsets = plan->on[WDR_FX_MISMATCH] || plan->on[WDR_FX_KTC];
    for (int j = 0; j < n; j++) {
        p[j] = pixel_inputs(s, plan, i0 + j, &mask[j]);
        k[j] = guess_node(tab, p[j].ie);
    }
    for (int j = 0; offsets && j < n; j++)
        k[j] = refine_guess(tab, &p[j], k[j]);
}

/* Stage three: the crossing, the held value, and shot noise on top. */
static inline void pixel_hold(const wdr_sim *s, const sim_plan *plan, const sim_ramp_table *tab, sim_px *p, int k,
                              unsigned mask, long i, int need_t, double *v, double *t)
{
    sim_cross c = settle(tab, p, k);
    hold_at(tab, p, c, need_t, v, t);
    if ((mask & SIM_BAND_SHOT) && p->ie * *t > 0)
        hold_at(tab, p, add_shot_noise(s, plan, tab, i, p, c.k, *t), need_t, v, t);
}

static int needs_cross_time(const sim_plan *plan) { return plan->on[WDR_FX_SHOT] || plan->on[WDR_FX_LEAKAGE]; }

/* One row's pixels through reset, integration and the compare: held voltages and times. */
void sim_expose_row(const wdr_sim *s, const sim_plan *plan, const sim_ramp_table *tab, int row, float *v_hold,
                    float *t_cross)
{
    sim_px p[BATCH];
    unsigned mask[BATCH]; /* not uint8_t: a char store may alias the plan and force reloads */
    int k[BATCH], need_t = needs_cross_time(plan);
    for (int x0 = 0; x0 < s->width; x0 += BATCH) {
        int n = s->width - x0 < BATCH ? s->width - x0 : BATCH;
        long i0 = (long)row * s->width + x0;
        batch_guess(s, plan, tab, i0, n, p, k, mask);
        for (int j = 0; j < n; j++) {
            double v, t;
            pixel_hold(s, plan, tab, &p[j], k[j], mask[j], i0 + j, need_t, &v, &t);
            v_hold[x0 + j] = (float)v;
            t_cross[x0 + j] = (float)t;
        }
    }
}

/* Droop until the read, source follower, read noise and the ADC line for n pixels from i0:
 * codes before rounding. Plain loops over arrays, so the compiler can vectorise them. */
static void read_batch(const wdr_sim *s, const sim_plan *plan, long i0, int n, const float *v, const float *t,
                       double t_int, double t_after, double *code)
{
    const sim_fixed_view *f = &plan->fixed;
    double g = s->nom.gamma, g2 = g * g, phi = s->nom.phi2f, leak = plan->leak_v_per_s;
    double sf_k[BATCH];
    for (int j = 0; j < n; j++)
        sf_k[j] = f->sf_k[(i0 + j) * f->stride];
    for (int j = 0; j < n; j++) {
        double vg = v[j] - leak * (t_int - t[j] + t_after);
        double disc = g2 + 4.0 * (sf_k[j] + vg);
        disc = disc > g2 ? disc : g2; /* below cut-off the follower sits at -phi, as in pixel.c */
        double r = 0.5 * (sqrt(disc) - g);
        code[j] = plan->adc_scale * (r * r - phi) + plan->adc_zero;
    }
    if (!plan->on[WDR_FX_READ])
        return;
    double volts = plan->adc_scale * s->board.read_noise_v;
    for (int j = 0; j < n; j++)
        code[j] += volts * sim_normal((uint32_t)sim_rng_u64(s->frame_seed, SIM_RNG_READ, (uint64_t)(i0 + j)));
}

/* Codes as stored: a float frame honours adc_quant and clipping; an integer frame always
 * holds rounded in-range codes. */
static void store_batch(const sim_plan *plan, const double *code, int n, float *out_f, uint16_t *out_u16)
{
    double full = plan->adc_full;
    if (out_u16) {
        for (int j = 0; j < n; j++) {
            double c = code[j] < 0 ? 0 : (code[j] > full ? full : code[j]);
            out_u16[j] = (uint16_t)(int)(c + 0.5);
        }
        return;
    }
    for (int j = 0; j < n; j++) {
        double c = plan->on[WDR_FX_ADC_QUANT] ? round_half_up(code[j]) : code[j];
        out_f[j] = (float)(plan->on[WDR_FX_CLIPPING] ? clampd(c, 0.0, full) : c);
    }
}

void sim_read_row(const wdr_sim *s, const sim_plan *plan, double t_int, int row, const float *v_hold,
                  const float *t_cross, double t_after, float *out_f, uint16_t *out_u16)
{
    double code[BATCH];
    for (int x0 = 0; x0 < s->width; x0 += BATCH) {
        int n = s->width - x0 < BATCH ? s->width - x0 : BATCH;
        read_batch(s, plan, (long)row * s->width + x0, n, v_hold + x0, t_cross + x0, t_int, t_after, code);
        store_batch(plan, code, n, out_f ? out_f + x0 : NULL, out_u16 ? out_u16 + x0 : NULL);
    }
}

void sim_render_row(const wdr_sim *s, const sim_plan *plan, const sim_ramp_table *tab, int row, double t_after,
                    float *out_f, uint16_t *out_u16)
{
    sim_px p[BATCH];
    unsigned mask[BATCH]; /* not uint8_t: a char store may alias the plan and force reloads */
    int k[BATCH], need_t = needs_cross_time(plan);
    float v[BATCH], t[BATCH];
    double code[BATCH];
    for (int x0 = 0; x0 < s->width; x0 += BATCH) {
        int n = s->width - x0 < BATCH ? s->width - x0 : BATCH;
        long i0 = (long)row * s->width + x0;
        batch_guess(s, plan, tab, i0, n, p, k, mask);
        for (int j = 0; j < n; j++) {
            double vj, tj;
            pixel_hold(s, plan, tab, &p[j], k[j], mask[j], i0 + j, need_t, &vj, &tj);
            v[j] = (float)vj; /* stored as float, as expose does: both paths give the same bits */
            t[j] = (float)tj;
        }
        read_batch(s, plan, i0, n, v, t, tab->t_int, t_after, code);
        store_batch(plan, code, n, out_f ? out_f + x0 : NULL, out_u16 ? out_u16 + x0 : NULL);
    }
}
