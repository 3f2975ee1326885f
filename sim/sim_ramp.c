/* Ramp tables: the LUT's DAC steps, or samples of a continuous V_ref(t), each node carrying the
 * nominal device's charge terms at its M2 turn-off level, and a guess table that takes a
 * photocurrent straight to its nominal crossing node (no scan over the steps per pixel). */
#include "sim_internal.h"
#include "wdr_err.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

#define CONTINUOUS_MIN_NODES 8192
#define CONTINUOUS_MAX_NODES 60000
#define GUESS_MAX_BUCKETS (1 << 18)

/* C(V) of the nominal junction, the derivative of wdr_pixel_charge. */
static double nominal_cap(const wdr_pixel_dev *d, double v)
{
    return d->c_pd * pow((1.0 + d->c_pd_ref_v / d->pb) / (1.0 + v / d->pb), d->mj);
}

static int fill_node(const wdr_sim *s, sim_node *nd, double t, double v)
{
    double h = wdr_pixel_turnoff_node(&s->nom, v);
    if (!(h > -s->nom.pb) || !isfinite(h))
        return WDR_E_INVAL;
    double ch = nominal_cap(&s->nom, h);
    nd->t = t;
    nd->inv_t = t > 0 ? (float)(1.0 / t) : 0.0f;
    nd->v = (float)v;
    nd->a = s->q0_nom - wdr_pixel_charge(&s->nom, h);
    nd->ch = ch;
    nd->ch2 = -0.5 * s->nom.mj / (s->nom.pb + h) * ch;
    return WDR_OK;
}

/* g < 0: a nominal pixel with current amps has crossed by node k. Falls with k on a rising ramp. */
static double nominal_g(const sim_node *nd, double amps) { return nd->a - amps * nd->t; }

static uint16_t first_crossed_nominal(const sim_ramp_table *tab, double amps)
{
    int lo = 0, hi = tab->n - 1;
    while (lo < hi) {
        int mid = (lo + hi) / 2;
        if (nominal_g(&tab->node[mid], amps) <= 0)
            hi = mid;
        else
            lo = mid + 1;
    }
    return (uint16_t)lo;
}

/* Span of currents whose crossing falls inside the ramp: a_k / t_k over the nodes. */
static void crossing_current_span(const sim_ramp_table *tab, double *lo, double *hi)
{
    *lo = INFINITY;
    *hi = 0;
    for (int k = 0; k < tab->n; k++) {
        const sim_node *nd = &tab->node[k];
        if (nd->t <= 0 || nd->a <= 0)
            continue;
        double i = nd->a / nd->t;
        *lo = i < *lo ? i : *lo;
        *hi = i > *hi ? i : *hi;
    }
    if (!(*hi > 0)) {
        *lo = 1e-20;
        *hi = 1e-3;
    }
}

static int build_guess(const wdr_sim *s, sim_ramp_table *tab)
{
    tab->dev = &s->nom;
    tab->q0_nom = s->q0_nom;
    double lo, hi;
    crossing_current_span(tab, &lo, &hi);
    lo = fmax(lo * 0.5, 1e-30);
    hi = fmin(hi * 2.0, 1e30);
    tab->guess_base = sim_float_bits((float)lo) >> SIM_GUESS_SHIFT;
    uint32_t top = sim_float_bits((float)hi) >> SIM_GUESS_SHIFT;
    tab->n_guess = (int)(top - tab->guess_base + 1);
    if (tab->n_guess > GUESS_MAX_BUCKETS)
        tab->n_guess = GUESS_MAX_BUCKETS;
    tab->guess = malloc((size_t)tab->n_guess * sizeof *tab->guess);
    if (!tab->guess)
        return WDR_E_NOMEM;
    /* Bucket edges rise, so their crossing nodes fall: one search for the first edge, then a walk
     * down the nodes, n + n_guess steps in all instead of a search per bucket (which took a fifth
     * of an auto-exposure run, whose ramp changes every frame). Same table: the search finds the
     * first node whose condition holds, and the condition is monotone in the node. */
    int k = 0;
    for (int b = 0; b < tab->n_guess; b++) {
        double edge = sim_bits_float((tab->guess_base + (uint32_t)b) << SIM_GUESS_SHIFT);
        if (b == 0)
            k = first_crossed_nominal(tab, edge);
        while (k > 0 && nominal_g(&tab->node[k - 1], edge) <= 0)
            k--;
        tab->guess[b] = (uint16_t)k;
    }
    return WDR_OK;
}

void sim_table_free(sim_ramp_table *t)
{
    free(t->node);
    free(t->guess);
    memset(t, 0, sizeof *t);
}

static double code_volts(const wdr_lut_view *lut, uint16_t code)
{
    double full = (double)((1u << lut->h.dac_bits) - 1u);
    return lut->h.dac_lo_v + code * ((double)lut->h.dac_hi_v - lut->h.dac_lo_v) / full;
}

/* Consecutive entries with one code are one step: merging them is exact, as the pixel only
 * sees the voltage, and it shortens the search. */
static int count_steps(const wdr_lut_view *lut)
{
    int n = 0;
    uint16_t prev = 0;
    for (uint32_t i = 0; i < lut->h.entry_count; i++) {
        uint32_t t;
        uint16_t code;
        wdr_lut_entry(lut, i, &t, &code);
        if (i > 0 && code < prev)
            return WDR_E_INVAL; /* a falling ramp would break the monotone crossing search */
        n += (i == 0 || code != prev);
        prev = code;
    }
    return n;
}

int sim_table_from_lut(const wdr_sim *s, const wdr_lut_view *lut, sim_ramp_table *out)
{
    memset(out, 0, sizeof *out);
    int n = count_steps(lut);
    if (n <= 0 || n > SIM_MAX_NODES)
        return WDR_E_INVAL;
    double tick = (lut->h.tick_ps + lut->tick_frac_q16 / 65536.0) * 1e-12; /* auto exposure's fraction */
    out->node = malloc((size_t)n * sizeof *out->node);
    if (!out->node)
        return WDR_E_NOMEM;
    out->n = n;
    out->t_int = lut->h.t_integration_ticks * tick;
    int k = -1;
    uint16_t prev = 0;
    for (uint32_t i = 0; i < lut->h.entry_count; i++) {
        uint32_t t;
        uint16_t code;
        wdr_lut_entry(lut, i, &t, &code);
        if (k >= 0 && code == prev)
            continue;
        prev = code;
        if (k >= 0) { /* the previous step ends where this one starts */
            out->node[k].t = t * tick;
            out->node[k].inv_t = (float)(1.0 / (t * tick));
        }
        if (fill_node(s, &out->node[++k], out->t_int, code_volts(lut, code)))
            return sim_table_free(out), WDR_E_INVAL;
    }
    return build_guess(s, out);
}

static double clampd(double x, double lo, double hi) { return x < lo ? lo : (x > hi ? hi : x); }

/* Resample a piecewise-linear ramp finely enough that interpolating the crossing condition
 * linearly between nodes is exact to far below a microvolt. */
int sim_table_from_ramp(const wdr_sim *s, const double *t, const double *v, int n, double t_int,
                        sim_ramp_table *out)
{
    memset(out, 0, sizeof *out);
    if (n < 2 || t[0] < 0)
        return WDR_E_INVAL;
    for (int i = 0; i < n; i++)
        if (!isfinite(t[i]) || !isfinite(v[i]) || (i > 0 && (t[i] <= t[i - 1] || v[i] < v[i - 1])))
            return WDR_E_INVAL;
    int per_seg = (CONTINUOUS_MIN_NODES + n - 2) / (n - 1);
    if ((long)per_seg * (n - 1) > CONTINUOUS_MAX_NODES)
        per_seg = 1;
    int lead = t[0] > 0, tail = t_int > t[n - 1];
    out->n = lead + per_seg * (n - 1) + 1 + tail;
    if (out->n > SIM_MAX_NODES)
        return WDR_E_INVAL;
    out->node = malloc((size_t)out->n * sizeof *out->node);
    if (!out->node)
        return WDR_E_NOMEM;
    out->continuous = 1;
    out->t_int = t_int > t[n - 1] ? t_int : t[n - 1];
    double lo = s->board.dac_lo_v, hi = s->board.dac_hi_v;
    int k = 0, rc = WDR_OK;
    if (lead)
        rc |= fill_node(s, &out->node[k++], 0.0, clampd(v[0], lo, hi));
    for (int i = 0; i + 1 < n; i++)
        for (int j = 0; j < per_seg; j++) {
            double f = (double)j / per_seg;
            double vv = clampd(v[i] + f * (v[i + 1] - v[i]), lo, hi);
            rc |= fill_node(s, &out->node[k++], t[i] + f * (t[i + 1] - t[i]), vv);
        }
    rc |= fill_node(s, &out->node[k++], t[n - 1], clampd(v[n - 1], lo, hi));
    if (tail)
        rc |= fill_node(s, &out->node[k++], t_int, clampd(v[n - 1], lo, hi));
    if (rc)
        return sim_table_free(out), WDR_E_INVAL;
    return build_guess(s, out);
}
