/* Defective pixels (effect "defects"): planted at known positions and rates, simulated by their
 * physics after the healthy pixels of a batch ran. A dead photodiode gives no current, a hot
 * one a large dark current: their crossing is searched again with that current. A stuck hold
 * node sits at a fixed voltage the follower reads; a saturated column sits at the ADC's rail.
 * Defective pixels carry no kTC or shot noise (they are flagged whatever their noise). */
#include "sim_internal.h"
#include "sim_rng.h"
#include "wdr_err.h"
#include <math.h>
#include <stdlib.h>

#define HOT_AMPS_DEFAULT 1e-11

static const char *const kind_names[WDR_DEFECT_KINDS] = {"none", "dead", "stuck", "hot", "saturated"};

const char *wdr_defect_name(int kind) { return kind >= 0 && kind < WDR_DEFECT_KINDS ? kind_names[kind] : "?"; }

void sim_defects_free(wdr_sim *s)
{
    free(s->defects);
    free(s->defect_row_start);
    s->defects = NULL;
    s->defect_row_start = NULL;
    s->n_defects = 0;
}

static int check_defects(const wdr_sim *s, const wdr_sim_defects *d)
{
    long np = (long)s->width * s->height;
    for (int k = 1; k < WDR_DEFECT_KINDS; k++)
        if (!(d->ppm[k] >= 0 && d->ppm[k] <= 1e6))
            return WDR_E_INVAL;
    if (!(d->hot_amps >= 0 && d->hot_amps <= SIM_MAX_AMPS) || d->n_listed < 0)
        return WDR_E_INVAL;
    for (int j = 0; j < d->n_listed; j++)
        if (d->listed_index[j] < 0 || d->listed_index[j] >= np || d->listed_kind[j] <= WDR_DEFECT_NONE ||
            d->listed_kind[j] >= WDR_DEFECT_KINDS)
            return WDR_E_INVAL;
    return WDR_OK;
}

/* Kinds per pixel: each rate draws distinct healthy pixels, then the listed ones override. */
static void draw_kinds(const wdr_sim *s, const wdr_sim_defects *d, uint8_t *kind)
{
    long np = (long)s->width * s->height;
    uint64_t seed = d->seed ? d->seed : s->chip_seed, draw = 0;
    for (int k = 1; k < WDR_DEFECT_KINDS; k++) {
        long want = lround(d->ppm[k] * (double)np / 1e6), got = 0;
        while (got < want && got < np) {
            long i = (long)(sim_rng_u64(seed, SIM_RNG_DEFECT_POS, draw++) % (uint64_t)np);
            if (!kind[i])
                kind[i] = (uint8_t)k, got++;
        }
    }
    for (int j = 0; j < d->n_listed; j++)
        kind[d->listed_index[j]] = d->listed_kind[j];
}

int wdr_sim_set_defects(wdr_sim *s, const wdr_sim_defects *d)
{
    long np = (long)s->width * s->height;
    sim_defects_free(s);
    s->plan_stale = 1;
    if (!d)
        return WDR_OK;
    if (check_defects(s, d))
        return WDR_E_INVAL;
    uint8_t *kind = calloc((size_t)np, 1);
    s->defect_row_start = calloc((size_t)s->height + 1, sizeof(long));
    if (!kind || !s->defect_row_start) {
        free(kind);
        sim_defects_free(s);
        return WDR_E_NOMEM;
    }
    draw_kinds(s, d, kind);
    long n = 0;
    for (long i = 0; i < np; i++)
        n += kind[i] != 0;
    s->defects = malloc(sizeof(sim_defect) * (size_t)(n ? n : 1));
    if (!s->defects) {
        free(kind);
        sim_defects_free(s);
        return WDR_E_NOMEM;
    }
    /* a stuck node sits somewhere in the DAC's span, the same place every frame */
    double lo = s->board.dac_lo_v, span = s->board.dac_hi_v - s->board.dac_lo_v;
    uint64_t seed = d->seed ? d->seed : s->chip_seed;
    for (long i = 0, m = 0; i < np; i++) {
        if ((i % s->width) == 0)
            s->defect_row_start[i / s->width] = m;
        if (!kind[i])
            continue;
        double u = (double)(sim_rng_u64(seed, SIM_RNG_DEFECT_V, (uint64_t)i) >> 11) / 9007199254740992.0;
        s->defects[m++] = (sim_defect){i, kind[i], (float)(lo + span * (0.2 + 0.6 * u))};
    }
    s->defect_row_start[s->height] = n;
    s->n_defects = n;
    s->hot_amps = d->hot_amps > 0 ? d->hot_amps : HOT_AMPS_DEFAULT;
    free(kind);
    return WDR_OK;
}

void wdr_sim_defect_map(const wdr_sim *s, uint8_t *kind)
{
    memset(kind, 0, (size_t)s->width * (size_t)s->height);
    for (long j = 0; j < s->n_defects; j++)
        kind[s->defects[j].i] = s->defects[j].kind;
}

long wdr_sim_defect_count(const wdr_sim *s, int kind)
{
    long n = 0;
    for (long j = 0; j < s->n_defects; j++)
        n += kind == WDR_DEFECT_NONE || s->defects[j].kind == kind;
    return n;
}

/* Defects of the batch [i0, i0 + n): a range of the sorted list (a batch never spans rows). */
static void batch_range(const wdr_sim *s, long i0, int n, long *first, long *end)
{
    long r = i0 / s->width, j = s->defect_row_start[r], e = s->defect_row_start[r + 1];
    while (j < e && s->defects[j].i < i0)
        j++;
    *first = j;
    while (e > j && s->defects[e - 1].i >= i0 + n)
        e--;
    *end = e;
}

void sim_defects_hold(const wdr_sim *s, const sim_plan *plan, const sim_ramp_table *tab, long i0, int n, float *v_hold,
                      float *t_cross)
{
    long j, e;
    if (!plan->on[WDR_FX_DEFECTS] || !s->n_defects)
        return;
    const sim_fixed_view f = plan->fixed;
    const long st = f.stride;
    for (batch_range(s, i0, n, &j, &e); j < e; j++) {
        const sim_defect *d = &s->defects[j];
        if (d->kind != WDR_DEFECT_DEAD && d->kind != WDR_DEFECT_HOT)
            continue;
        long i = d->i;
        double ie = 0; /* dead: the photodiode passes no current at all */
        if (d->kind == WDR_DEFECT_HOT) {
            double a = s->amps ? s->amps[i] : s->uniform_amps;
            ie = (a + (plan->on[WDR_FX_DARK] ? f.idark[i * st] : 0.0) + s->hot_amps) * f.cinv[i * st];
        }
        sim_px p = {f.dq0[i * st], f.dvt2[i * st], ie};
        double v, t;
        sim_pixel_hold(tab, &p, 1, &v, &t);
        v_hold[i - i0] = (float)v;
        t_cross[i - i0] = (float)t;
    }
}

void sim_defects_codes(const wdr_sim *s, const sim_plan *plan, long i0, int n, double *code)
{
    long j, e;
    if (!plan->on[WDR_FX_DEFECTS] || !s->n_defects)
        return;
    const uint64_t key = sim_rng_key(s->frame_seed, SIM_RNG_READ);
    const double read_codes = plan->adc_scale * s->board.read_noise_v;
    for (batch_range(s, i0, n, &j, &e); j < e; j++) {
        const sim_defect *d = &s->defects[j];
        long i = d->i;
        if (d->kind == WDR_DEFECT_SATURATED) {
            code[i - i0] = plan->adc_full; /* the column output at the ADC's top rail */
        } else if (d->kind == WDR_DEFECT_STUCK) {
            /* the follower reads the node where it is stuck: no droop, the column's read noise */
            double c = plan->adc_scale * sim_sf_out(s, plan->fixed.sf_k[i * plan->fixed.stride], d->v_stuck) +
                       plan->adc_zero;
            if (plan->on[WDR_FX_READ])
                c += read_codes * sim_normal((uint32_t)sim_rng_at(key, (uint64_t)i));
            code[i - i0] = c;
        }
    }
}
