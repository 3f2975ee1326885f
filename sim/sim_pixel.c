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

/* The guess table as the pixel loops use it, copied into locals: read through the table
 * pointer, the compiler would reload it after every store to the batch arrays. */
typedef struct sim_guess {
    const uint16_t *entry;
    int32_t base, last;
} sim_guess;

static inline sim_guess guess_view(const sim_ramp_table *tab)
{
    return (sim_guess){tab->guess, (int32_t)tab->guess_base, tab->n_guess - 1};
}

/* The float bits of a positive current rise with it: their top bits are a cheap log2. */
static inline int guess_at(sim_guess g, double amps)
{
    float f = (float)amps; /* currents are at most 1 A (checked where they come in) */
    int32_t u;             /* as a signed integer, a negative current sorts below every positive one */
    memcpy(&u, &f, sizeof u);
    int32_t b = (u >> SIM_GUESS_SHIFT) - g.base;
    b = b < 0 ? 0 : b;
    return g.entry[b > g.last ? g.last : b];
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
static inline int refine_guess(const sim_node *node, sim_guess g, const sim_px *p, int k)
{
    const sim_node *nd = &node[k];
    return guess_at(g, p->ie - (p->e0 - p->d * (nd->ch + p->d * nd->ch2)) * nd->inv_t);
}

/* The second guess runs one step high for about one pixel in eleven (a bucket edge mid-step,
 * or offsets that move the crossing far from the first guess). Stepping back here, in a tight
 * loop over the batch with no branch on the outcome, costs less than the branch settle would
 * mispredict for those pixels (measured: 3 % of ideal + mismatch). */
static inline int step_back_if_crossed(const sim_node *node, const sim_px *p, int k)
{
    return k - (k > 0 && crossing_g(&node[k - 1], p) <= 0);
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

/* When M2 turned off within step k (the condition falls linearly in time there): at the step's
 * start if the node was already past the turn-off level when V_ref jumped (g_start <= 0). */
static inline double cross_time(const sim_px *p, const sim_node *pv, const sim_node *nd, double gk, double g_start)
{
    if (g_start <= 0)
        return pv->t;
    if (!(p->ie > 0))
        return nd->t;
    return clampd((gk + p->ie * nd->t) / p->ie, pv->t, nd->t);
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
     * step when the collected charge reached its threshold. Which one happens is as good as
     * random from pixel to pixel, so neither is chosen by a branch: with g_start > 0 the
     * fraction f is exactly 1 and pv->v + dv is exactly nd->v (float voltages, double sums). */
    double below = 0.5 * (g_start - fabs(g_start)); /* min(g_start, 0), exact, and no branch for the compiler */
    double f = gp / (gp - below);                    /* gp > 0: node k-1 was not crossed */
    *v_hold = pv->v + f * dv;
    *t_cross = need_t ? cross_time(p, pv, nd, gk, g_start) : nd->t;
}

void sim_pixel_hold(const sim_ramp_table *tab, const sim_px *p, int need_t, double *v_hold, double *t_cross)
{
    sim_guess g = guess_view(tab);
    int k = refine_guess(tab->node, g, p, guess_at(g, p->ie));
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

/* Electrons collected until M2 turned off are Poisson (Gaussian at these counts): move the
 * charge balance by one draw and find the crossing again. One sigma is several DAC steps in
 * bright pixels (hundreds of electrons against tens per step), so the search starts from a
 * fresh guess for the new charge offset, not from the old crossing (a walk of many steps). */
static inline sim_cross add_shot_noise(const wdr_sim *s, const sim_plan *plan, const sim_ramp_table *tab, long i,
                                       sim_px *p, int k, double t)
{
    double sigma = sqrt(SIM_Q_E * p->ie * t * plan->fixed.cinv[i * plan->fixed.stride]);
    p->e0 -= sigma * sim_normal((uint32_t)sim_rng_u64(s->frame_seed, SIM_RNG_SHOT, (uint64_t)i));
    return settle(tab, p, refine_guess(tab->node, guess_view(tab), p, k));
}

#define BATCH 32

/* Which banded effects run for each pixel of a batch: one mask for all unless the plan
 * decides per current band. */
static void batch_masks(const wdr_sim *s, const sim_plan *plan, long i0, int n, unsigned *restrict mask)
{
    const float *amps = s->amps;
    if (!plan->banded || !amps) {
        unsigned m = plan->band_mask[plan->banded ? sim_band_of(plan, s->uniform_amps) : 0];
        for (int j = 0; j < n; j++)
            mask[j] = m;
        return;
    }
    for (int j = 0; j < n; j++)
        mask[j] = plan->band_mask[sim_band_of(plan, amps[i0 + j])];
}

/* Stage one for a batch of pixels: fixed pattern, current (plus dark current where it runs),
 * the first guess from the current, and reset noise. Every per-batch value in a local. */
static void batch_inputs(const wdr_sim *s, const sim_plan *plan, sim_guess g, long i0, int n, sim_px *restrict p,
                         int *restrict k, const unsigned *restrict mask)
{
    const sim_fixed_view f = plan->fixed;
    const long st = f.stride, o = i0 * st;
    const float *amps = s->amps ? s->amps + i0 : NULL, *dq0 = f.dq0 + o, *dvt2 = f.dvt2 + o, *cinv = f.cinv + o;
    const float *idark = f.idark + o, *ktc_q = f.ktc_q + o;
    const double uniform = s->uniform_amps;
    for (int j = 0; j < n; j++) {
        double a = amps ? amps[j] : uniform;
        a += (mask[j] & SIM_BAND_DARK) ? idark[j * st] : 0.0f;
        p[j] = (sim_px){dq0[j * st], dvt2[j * st], a * cinv[j * st]};
        k[j] = guess_at(g, p[j].ie); /* the nominal crossing: kTC noise only moves the charge offset */
    }
    if (!plan->on[WDR_FX_KTC])
        return;
    const uint64_t key = sim_rng_key(s->frame_seed, SIM_RNG_KTC);
    for (int j = 0; j < n; j++)
        if (mask[j] & SIM_BAND_KTC)
            p[j].e0 += ktc_q[j * st] * sim_normal((uint32_t)sim_rng_at(key, (uint64_t)(i0 + j)));
}

/* Stages one and two for a batch of pixels: inputs and the two guesses. Stage by stage, the
 * table look-ups of neighbouring pixels overlap instead of waiting on each other. */
static inline void batch_guess(const wdr_sim *s, const sim_plan *plan, const sim_ramp_table *tab, long i0, int n,
                               sim_px *restrict p, int *restrict k, unsigned *restrict mask)
{
    const sim_guess g = guess_view(tab);
    const sim_node *node = tab->node;
    batch_masks(s, plan, i0, n, mask);
    batch_inputs(s, plan, g, i0, n, p, k, mask);
    if (plan->on[WDR_FX_MISMATCH] || plan->on[WDR_FX_KTC])
        for (int j = 0; j < n; j++)
            k[j] = step_back_if_crossed(node, &p[j], refine_guess(node, g, &p[j], k[j]));
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
        sim_defects_hold(s, plan, tab, i0, n, v_hold + x0, t_cross + x0);
    }
}

/* Droop until the read, source follower, read noise and the ADC line for n pixels from i0:
 * codes before rounding. Plain loops over arrays, so the compiler can vectorise them. */
static inline void follower_adc(const wdr_sim *s, const sim_plan *plan, int n, const float *restrict v,
                                const float *restrict t, const float *restrict sf_k, long st, double t_int,
                                double t_after, double *restrict code)
{
    const double g = s->nom.gamma, g2 = g * g, phi = s->nom.phi2f, leak = plan->leak_v_per_s;
    const double scale = plan->adc_scale, zero = plan->adc_zero;
    for (int j = 0; j < n; j++) {
        double vg = v[j] - leak * (t_int - t[j] + t_after);
        double disc = g2 + 4.0 * (sf_k[j * st] + vg);
        disc = disc > g2 ? disc : g2; /* below cut-off the follower sits at -phi, as in pixel.c */
        double r = 0.5 * (sqrt(disc) - g);
        code[j] = scale * (r * r - phi) + zero;
    }
}

static void read_batch(const wdr_sim *s, const sim_plan *plan, long i0, int n, const float *v, const float *t,
                       double t_int, double t_after, double *code)
{
    const long st = plan->fixed.stride;
    const float *sf_k = plan->fixed.sf_k + i0 * st;
    if (st == 1) /* a constant stride: the loop vectorises */
        follower_adc(s, plan, n, v, t, sf_k, 1, t_int, t_after, code);
    else
        follower_adc(s, plan, n, v, t, sf_k, 0, t_int, t_after, code);
    if (!plan->on[WDR_FX_READ])
        return;
    const double volts = plan->adc_scale * s->board.read_noise_v;
    const uint64_t key = sim_rng_key(s->frame_seed, SIM_RNG_READ);
    for (int j = 0; j < n; j++)
        code[j] += volts * sim_normal((uint32_t)sim_rng_at(key, (uint64_t)(i0 + j)));
}

/* Codes as stored: a float frame honours adc_quant and clipping; an integer frame always
 * holds rounded in-range codes. */
static void store_batch(const sim_plan *plan, const double *restrict code, int n, float *restrict out_f,
                        uint16_t *restrict out_u16)
{
    double full = plan->adc_full;
    if (out_u16) {
        for (int j = 0; j < n; j++) { /* max and min, in this order, so the loop vectorises */
            double c = code[j] > 0 ? code[j] : 0.0;
            c = c < full ? c : full;
            out_u16[j] = (uint16_t)(int32_t)(c + 0.5);
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
        sim_defects_codes(s, plan, (long)row * s->width + x0, n, code);
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
        sim_defects_hold(s, plan, tab, i0, n, v, t);
        read_batch(s, plan, i0, n, v, t, tab->t_int, t_after, code);
        sim_defects_codes(s, plan, i0, n, code);
        store_batch(plan, code, n, out_f ? out_f + x0 : NULL, out_u16 ? out_u16 + x0 : NULL);
    }
}
