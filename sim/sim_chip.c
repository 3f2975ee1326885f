/* A chip: board, nominal devices and the fixed pattern drawn once from the chip seed; the
 * effect switches; the ramp and the illumination it will see next. */
#include "sim_internal.h"
#include "sim_rng.h"
#include "wdr_err.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

static const char *const effect_names[WDR_FX_COUNT] = {
    "mismatch", "dark", "shot", "ktc", "read", "dac_quant", "adc_quant", "leakage", "clipping",
    "defects"};

const char *wdr_effect_name(int fx) { return fx >= 0 && fx < WDR_FX_COUNT ? effect_names[fx] : "?"; }

int wdr_effect_from_name(const char *name)
{
    for (int i = 0; i < WDR_FX_COUNT; i++)
        if (!strcmp(name, effect_names[i]))
            return i;
    return -1;
}

/* Reset level through M1, closed form of wdr_pixel_reset_level: with s = sqrt(phi + v),
 * s^2 + gamma s - (V_gate + phi + gamma sqrt(phi) - vt0_1) = 0. */
static double reset_level(const wdr_pixel_dev *d, double vt0_m1)
{
    double g = d->gamma, r = d->reset_gate + d->phi2f + g * sqrt(d->phi2f) - vt0_m1;
    double s = 0.5 * (-g + sqrt(g * g + 4.0 * (r > 0 ? r : 0)));
    double v = s * s - d->phi2f;
    return v < d->vdd ? v : d->vdd;
}

static double nominal_cap(const wdr_pixel_dev *d, double v)
{
    return d->c_pd * pow((1.0 + d->c_pd_ref_v / d->pb) / (1.0 + v / d->pb), d->mj);
}

double sim_reset_dq0(const wdr_sim *s, double dvt1)
{
    return wdr_pixel_charge(&s->nom, reset_level(&s->nom, s->nom.vt0_m1 + dvt1)) - s->q0_nom;
}

static double sf_constant(const wdr_pixel_dev *d, double vt0_m3, double beta3)
{
    return d->phi2f + d->gamma * sqrt(d->phi2f) - vt0_m3 - sqrt(2.0 * d->sf_bias / beta3);
}

static double pelgrom_sigma(double a, wdr_mos m) { return a / sqrt(m.w_um * m.l_um); }

static double draw(uint64_t seed, int stream, long i)
{
    return sim_normal((uint32_t)sim_rng_u64(seed, (uint32_t)stream, (uint64_t)i));
}

/* One pixel's devices from the chip seed: Pelgrom sigmas from the board's A_VT and A_beta. */
static void draw_pixel(wdr_sim *s, long i)
{
    const wdr_board *b = &s->board;
    const wdr_pixel_dev *n = &s->nom;
    uint64_t seed = s->chip_seed;
    double vt1 = n->vt0_m1 + 1e-3 * pelgrom_sigma(b->avt_mv_um, b->m1) * draw(seed, SIM_RNG_VT1, i);
    double dvt2 = 1e-3 * pelgrom_sigma(b->avt_mv_um, b->m2) * draw(seed, SIM_RNG_VT2, i);
    double vt3 = n->vt0_m3 + 1e-3 * pelgrom_sigma(b->avt_mv_um, b->m3) * draw(seed, SIM_RNG_VT3, i);
    double beta = n->beta3 * (1.0 + 0.01 * pelgrom_sigma(b->abeta_pct_um, b->m3) * draw(seed, SIM_RNG_BETA3, i));
    double c = fmax(0.5, 1.0 + 0.01 * b->c_pd_sigma_pct * draw(seed, SIM_RNG_CPD, i));
    double v_n0 = reset_level(n, vt1);
    s->fx.dq0[i] = (float)(wdr_pixel_charge(n, v_n0) - s->q0_nom);
    s->fx.dvt2[i] = (float)dvt2;
    s->fx.cinv[i] = (float)(1.0 / c);
    s->fx.idark[i] = (float)(b->dark_current_a * exp(b->dark_sigma_ln * draw(seed, SIM_RNG_DARK, i)));
    s->fx.sf_k[i] = (float)sf_constant(n, vt3, fmax(beta, 1e-3 * n->beta3));
    s->fx.ktc_q[i] = (float)(sqrt(SIM_K_B * b->temperature_k * c * nominal_cap(n, v_n0)) / c);
}

static void set_nominal(wdr_sim *s)
{
    const wdr_pixel_dev *n = &s->nom;
    s->v_n0_nom = reset_level(n, n->vt0_m1);
    s->q0_nom = wdr_pixel_charge(n, s->v_n0_nom);
    s->sf_k_nom = sf_constant(n, n->vt0_m3, n->beta3);
    s->ktc_q_nom = sqrt(SIM_K_B * s->board.temperature_k * nominal_cap(n, s->v_n0_nom));
    float nominal[6] = {0.0f, 0.0f, 1.0f, (float)s->board.dark_current_a, (float)s->sf_k_nom, (float)s->ktc_q_nom};
    memcpy(s->nominal_fx, nominal, sizeof nominal);
}

static int alloc_fixed(wdr_sim *s, long n)
{
    float **arrays[] = {&s->fx.dq0, &s->fx.dvt2, &s->fx.cinv, &s->fx.idark, &s->fx.sf_k, &s->fx.ktc_q,
                        &s->hold_v, &s->hold_t};
    for (size_t k = 0; k < sizeof arrays / sizeof arrays[0]; k++)
        if (!(*arrays[k] = malloc((size_t)n * sizeof(float))))
            return WDR_E_NOMEM;
    return WDR_OK;
}

wdr_sim *wdr_sim_create(const wdr_board *b, uint64_t chip_seed)
{
    wdr_sim *s = calloc(1, sizeof *s);
    if (!s)
        return NULL;
    sim_rng_init();
    s->board = *b;
    s->chip_seed = chip_seed;
    s->width = b->width;
    s->height = b->height;
    s->tolerance_lsb = 0.25;
    s->plan_stale = 1;
    s->uniform_amps = b->i_center_a;
    s->scene_i_min = s->scene_i_max = b->i_center_a;
    for (int k = 0; k < WDR_FX_COUNT; k++)
        s->mode[k] = WDR_FX_ON;
    wdr_pixel_nominal(b, &s->nom);
    set_nominal(s);
    long n = (long)s->width * s->height;
    if (alloc_fixed(s, n)) {
        wdr_sim_destroy(s);
        return NULL;
    }
    for (long i = 0; i < n; i++)
        draw_pixel(s, i);
    return s;
}

void wdr_sim_destroy(wdr_sim *s)
{
    if (!s)
        return;
    float *arrays[] = {s->fx.dq0, s->fx.dvt2, s->fx.cinv, s->fx.idark, s->fx.sf_k, s->fx.ktc_q,
                       s->hold_v, s->hold_t, s->amps};
    for (size_t k = 0; k < sizeof arrays / sizeof arrays[0]; k++)
        free(arrays[k]);
    sim_table_free(&s->stepped);
    sim_table_free(&s->continuous);
    sim_defects_free(s);
    free(s);
}

void wdr_sim_set_effect(wdr_sim *s, int fx, wdr_fx_mode mode)
{
    if (fx >= 0 && fx < WDR_FX_COUNT && mode >= WDR_FX_OFF && mode <= WDR_FX_AUTO && s->mode[fx] != mode) {
        s->mode[fx] = mode;
        s->plan_stale = 1;
    }
}

wdr_fx_mode wdr_sim_get_effect(const wdr_sim *s, int fx)
{
    return fx >= 0 && fx < WDR_FX_COUNT ? s->mode[fx] : WDR_FX_OFF;
}

void wdr_sim_set_auto_tolerance(wdr_sim *s, double lsb)
{
    s->tolerance_lsb = lsb > 0 ? lsb : 0;
    s->plan_stale = 1;
}
void wdr_sim_set_threads(wdr_sim *s, int n) { s->threads = n > 0 ? n : 0; }
void wdr_sim_set_reference(wdr_sim *s, int reference)
{
    s->reference = reference != 0;
    s->plan_stale = 1;
}
const wdr_board *wdr_sim_board(const wdr_sim *s) { return &s->board; }

void wdr_sim_set_progress(wdr_sim *s, void (*fn)(void *ctx, int rows_done, int rows_total), void *ctx)
{
    s->progress = fn;
    s->progress_ctx = ctx;
}

/* The LUT is kept as bytes so a view stays valid; the continuous ramp is rebuilt from its
 * step mid-points unless the caller gave one. */
int wdr_sim_set_lut(wdr_sim *s, const wdr_lut_view *lut)
{
    if (!lut || !lut->entries || lut->h.entry_count == 0 || !(lut->h.dac_hi_v > lut->h.dac_lo_v))
        return WDR_E_INVAL;
    sim_ramp_table stepped;
    int rc = sim_table_from_lut(s, lut, &stepped);
    if (rc)
        return rc;
    sim_table_free(&s->stepped);
    s->stepped = stepped;
    s->have_lut = 1;
    s->exposed = 0;
    s->plan_stale = 1;
    if (s->caller_ramp)
        return WDR_OK;
    return wdr_sim_set_ramp(s, NULL, NULL, 0);
}

static int midpoint_ramp(wdr_sim *s)
{
    const sim_ramp_table *st = &s->stepped;
    double *t = malloc((size_t)(st->n + 1) * sizeof *t), *v = malloc((size_t)(st->n + 1) * sizeof *v);
    int rc = WDR_E_NOMEM;
    if (t && v) {
        int m = 0;
        for (int k = 0; k < st->n; k++) {
            double start = k ? st->node[k - 1].t : 0.0;
            t[m] = 0.5 * (start + st->node[k].t);
            v[m++] = st->node[k].v;
        }
        rc = m >= 2 ? sim_table_from_ramp(s, t, v, m, st->t_int, &s->continuous)
                    : sim_table_from_ramp(s, (double[]){0, st->t_int}, (double[]){v[0], v[0]}, 2, st->t_int,
                                          &s->continuous);
    }
    free(t);
    free(v);
    return rc;
}

int wdr_sim_set_ramp(wdr_sim *s, const double *t_s, const double *v, int n)
{
    if (n < 0 || (n > 0 && (!t_s || !v)))
        return WDR_E_INVAL;
    sim_table_free(&s->continuous);
    s->caller_ramp = n > 0;
    s->exposed = 0;
    s->plan_stale = 1;
    if (n > 0) {
        double t_int = s->have_lut ? s->stepped.t_int : t_s[n - 1];
        return sim_table_from_ramp(s, t_s, v, n, t_int, &s->continuous);
    }
    return s->have_lut ? midpoint_ramp(s) : WDR_OK;
}

int wdr_sim_set_uniform(wdr_sim *s, double amps)
{
    if (!(amps >= 0 && amps <= SIM_MAX_AMPS))
        return WDR_E_INVAL;
    free(s->amps);
    s->amps = NULL;
    s->uniform_amps = amps;
    s->scene_i_min = s->scene_i_max = amps;
    s->plan_stale = 1;
    return WDR_OK;
}

int wdr_sim_set_photocurrent(wdr_sim *s, const float *amps)
{
    long n = (long)s->width * s->height;
    double lo = INFINITY, hi = 0;
    for (long i = 0; i < n; i++) {
        if (!(amps[i] >= 0 && amps[i] <= SIM_MAX_AMPS))
            return WDR_E_INVAL;
        lo = amps[i] < lo ? amps[i] : lo;
        hi = amps[i] > hi ? amps[i] : hi;
    }
    if (!s->amps && !(s->amps = malloc((size_t)n * sizeof *s->amps)))
        return WDR_E_NOMEM;
    memcpy(s->amps, amps, (size_t)n * sizeof *amps);
    s->scene_i_min = lo;
    s->scene_i_max = hi;
    s->plan_stale = 1;
    return WDR_OK;
}

const float *wdr_sim_photocurrent(const wdr_sim *s, double *uniform_amps)
{
    *uniform_amps = s->uniform_amps;
    return s->amps;
}

/* Devices of pixel (x, y) as drawn for this chip: the calibration's ground truth. */
int wdr_sim_pixel_devices(const wdr_sim *s, int x, int y, wdr_sim_pixel_truth *out)
{
    if (x < 0 || y < 0 || x >= s->width || y >= s->height)
        return WDR_E_INVAL;
    long i = (long)y * s->width + x;
    double c = 1.0 / s->fx.cinv[i];
    out->dq0_c = (s->q0_nom + s->fx.dq0[i]) * c - s->q0_nom;
    out->dvt2_v = s->fx.dvt2[i];
    out->c_pd_scale = c;
    out->dark_a = s->fx.idark[i];
    out->sf_k_v = s->fx.sf_k[i];
    return WDR_OK;
}
