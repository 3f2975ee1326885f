/* Accuracy vs time for the on-the-fly correction: per table form, the firmware kernel's
 * ns/pixel against memcpy in the same run (of the raw frame alone, and of every byte the kernel
 * streams: raw in, table, corrected out), and the residual contrast error each form leaves on the
 * simulator (worst over 31 currents, 1e-14..1e-8 A, Reinhard, no DAC/ADC quantisation; the forms
 * on every operator are in bench_cal's last table).
 * Prints a table; asserts nothing about speed. --quick uses a small frame. */
#include "cal_select.h"
#include "correct.h"
#include "wdr_err.h"
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

static double now_s(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec + ts.tv_nsec * 1e-9;
}

typedef struct form_row {
    const char *name;
    int model, form, n_coeffs;
    int per_code; /* BASIS: tabulated per raw code by wdr_correct_per_code, as the firmware does */
} form_row;

static const form_row forms[] = {
    {"identity (no table)", WDR_MODEL_NONE, WDR_FORM_IDENTITY, 0, 0},
    {"poly-2 gain/offset (spline fit)", WDR_MODEL_SPLINE, WDR_FORM_POLY, 2, 0},
    {"Moebius, 1 divide (3-parameter)", WDR_MODEL_SIMPLE3, WDR_FORM_MOEBIUS, 3, 0},
    {"poly-3 (spline fit)", WDR_MODEL_SPLINE, WDR_FORM_POLY, 3, 0},
    {"poly-4 (spline fit)", WDR_MODEL_SPLINE, WDR_FORM_POLY, 4, 0},
    {"poly-5 (spline fit)", WDR_MODEL_SPLINE, WDR_FORM_POLY, 5, 0},
    {"poly-5 (4-parameter fit)", WDR_MODEL_COMPLEX4, WDR_FORM_POLY, 5, 0},
    {"poly-8 (spline fit)", WDR_MODEL_SPLINE, WDR_FORM_POLY, 8, 0},
    {"basis-4, shared 16 KiB (spline fit)", WDR_MODEL_SPLINE, WDR_FORM_BASIS, 4, 0},
    {"basis-8, shared 16 KiB (spline fit)", WDR_MODEL_SPLINE, WDR_FORM_BASIS, 8, 0},
    {"basis-4, per code 64 KiB (firmware)", WDR_MODEL_SPLINE, WDR_FORM_BASIS, 4, 1},
    {"basis-8, per code 128 KiB (firmware)", WDR_MODEL_SPLINE, WDR_FORM_BASIS, 8, 1},
};

/* The firmware's per-code points (wdr_fw_config.h: 4096 codes of 8 coefficients). */
static float code_points[4096 * 8];

/* As the firmware activates a BASIS table: one point per raw code. */
static int per_code(const form_row *f, wdr_cal_view *v)
{
    if (!f->per_code)
        return WDR_OK;
    int rc = wdr_correct_per_code(v, code_points, sizeof code_points / sizeof code_points[0]);
    if (rc)
        fprintf(stderr, "bench_correct: %s: per-code points refused: %s\n", f->name, wdr_strerror(rc));
    return rc;
}

/* ---- accuracy: calibrate a 64x48 chip and judge the table path ---- */

typedef struct chip {
    wdr_sim *sim;
    uint8_t *lut;
    wdr_cal_simsrc ss;
    wdr_cal_source src;
    wdr_cal_levels grid;
} chip;

static int chip_open(chip *c)
{
    wdr_board b;
    char err[512];
    wdr_board_defaults(&b);
    b.width = 64, b.height = 48;
    if (wdr_cal_sim_setup(&b, "reinhard", 5, 0, 0.06, &c->sim, &c->lut, err, sizeof err)) {
        fprintf(stderr, "bench_correct: %s\n", err);
        return 1;
    }
    wdr_sim_set_effect(c->sim, WDR_FX_DAC_QUANT, WDR_FX_OFF);
    c->ss = (wdr_cal_simsrc){c->sim, 0, 91};
    c->src = (wdr_cal_source){64, 48, wdr_cal_sim_capture, &c->ss};
    double amps[37];
    for (int k = 0; k < 37; k++)
        amps[k] = 1e-14 * pow(10, k / 6.0);
    return wdr_cal_acquire(&c->src, amps, 37, 1, 1, NULL, NULL, &c->grid, err, sizeof err);
}

/* Worst table-path contrast error of a form (100 sd of ln(x_hat/x)); the identity is judged as the raw
 * frame through the nominal curve's inverse, and *beyond gets the largest fraction of its pixels past
 * the curve. Analog chip: converters and temporal noise off. */
static double form_error(chip *c, const form_row *f, double *beyond)
{
    char err[512];
    wdr_cal_config cfg;
    wdr_cal_choice ch;
    wdr_cal_levels lv;
    wdr_cal_result res;
    uint8_t *tb = NULL;
    size_t tl;
    wdr_cal_view tab;
    int model = f->model == WDR_MODEL_NONE ? WDR_MODEL_SPLINE : f->model;
    int n_cur = model == WDR_MODEL_SIMPLE3 ? 3 : model == WDR_MODEL_COMPLEX4 ? 4 : 19;
    wdr_cal_config_defaults(&cfg, model);
    cfg.form = f->form == WDR_FORM_IDENTITY ? WDR_FORM_POLY : f->form;
    cfg.n_coeffs = f->n_coeffs ? f->n_coeffs : 5;
    cfg.range_lo = 1e-14, cfg.range_hi = 1e-8;
    if (wdr_cal_select_currents(&c->grid, &cfg, n_cur, 1e-14, 1e-8, 64, &ch, err, sizeof err) ||
        wdr_cal_levels_from_choice(&c->grid, &ch, &lv) || wdr_cal_fit_array(&lv, &cfg, &res, err, sizeof err) ||
        wdr_cal_build_table(&res, 1, 1, &tb, &tl, err, sizeof err) || wdr_cal_parse(tb, tl, &tab) ||
        per_code(f, &tab)) {
        fprintf(stderr, "bench_correct: %s: %s\n", f->name, err);
        return NAN;
    }
    double worst = 0;
    wdr_eval_opts eo = {.frames = 1};
    for (int k = 0; k < 31; k++) { /* the metrics of host/cal/metrics/cal_metrics.h, as wdrctl fpn report */
        wdr_eval_point p;
        eo.first_frame_no = 100 + k;
        if (wdr_eval_point_measure(&res, &tab, &c->src, 1e-14 * pow(1e6, (k + 0.37) / 31), &eo, &p))
            return NAN;
        worst = fmax(worst, f->form == WDR_FORM_IDENTITY ? p.before.sd_pct : p.table.sd_pct);
        if (f->form == WDR_FORM_IDENTITY)
            *beyond = fmax(*beyond, p.before.beyond_frac);
    }
    lv.dark = NULL;
    wdr_cal_levels_free(&lv);
    wdr_cal_result_free(&res);
    free(tb);
    return worst;
}

/* ---- speed: a synthetic table of each form on a bigger frame ---- */

static uint8_t *synthetic_table(const form_row *f, int w, int h, size_t *len)
{
    long np = (long)w * h;
    int nc = f->n_coeffs;
    float *coeffs = malloc(sizeof(float) * (size_t)(nc ? nc : 1) * (size_t)np);
    uint8_t *flags = calloc((size_t)np, 1);
    for (long i = 0; i < np; i++) {
        double jitter = 1e-3 * (double)((i * 2654435761u) % 1000) / 1000;
        for (int k = 0; k < nc; k++) {
            double v = f->form == WDR_FORM_MOEBIUS ? (k == 0 ? 1 + jitter : k == 1 ? 5 : 1e-6)
                                                   : (k < 2 ? 2047.5 * (1 + jitter) : 0.5 / (k + 1));
            coeffs[(long)k * np + i] = (float)v;
        }
    }
    flags[np / 2] = WDR_PIX_DEAD; /* one bad pixel, as on a real chip: the patch pass runs */
    wdr_cal_header hd = {.sensor_id = 1, .width = (uint16_t)w, .height = (uint16_t)h, .form = (uint16_t)f->form,
                         .n_coeffs = (uint16_t)nc, .model = WDR_MODEL_SPLINE, .in_scale = 2.0f / 4095,
                         .in_offset = -1, .out_scale = 16, .out_max = 65535, .raw_max = 4095, .bad_pixels = 1};
    uint8_t *buf;
    if (f->form == WDR_FORM_BASIS) { /* the largest shared block: a full 16 KiB, in the cache as in RAM */
        uint32_t points = WDR_CAL_MAX_SHARED_FLOATS / (uint32_t)nc;
        float *shared = malloc(sizeof(float) * WDR_CAL_MAX_SHARED_FLOATS);
        for (uint32_t j = 0; j < points * (uint32_t)nc; j++)
            shared[j] = (float)(1 + sin(0.01 * j));
        hd.shared_points = points;
        hd.in_scale = (float)(points - 1) / 4095, hd.in_offset = 0;
        *len = wdr_cal_size_basis((uint16_t)w, (uint16_t)h, (uint16_t)nc, points);
        buf = aligned_alloc(64, (*len + 63) & ~(size_t)63);
        wdr_cal_encode_basis(&hd, shared, coeffs, flags, buf);
        free(shared);
    } else {
        *len = wdr_cal_size((uint16_t)w, (uint16_t)h, (uint16_t)nc);
        buf = aligned_alloc(64, (*len + 63) & ~(size_t)63);
        wdr_cal_encode(&hd, coeffs, flags, buf);
    }
    free(coeffs);
    free(flags);
    return buf;
}

/* Best of a few rounds of reps: the least disturbed figure on a shared machine. */
static double time_kernel(const wdr_cal_view *v, const uint16_t *raw, uint16_t *out, int reps)
{
    double best = INFINITY;
    for (int round = 0; round < 5; round++) {
        double t0 = now_s();
        for (int r = 0; r < reps; r++)
            for (int row = 0; row < v->h.height; row++)
                wdr_correct_row(v, row, raw + (long)row * v->h.width, out + (long)row * v->h.width);
        best = fmin(best, (now_s() - t0) / reps);
    }
    return best;
}

static double time_memcpy(uint8_t *dst, const uint8_t *src, size_t bytes, int reps)
{
    double best = INFINITY;
    for (int round = 0; round < 5; round++) {
        double t0 = now_s();
        for (int r = 0; r < reps; r++) {
            memcpy(dst, src, bytes);
            __asm__ volatile("" : : "r"(dst) : "memory"); /* keep every copy */
        }
        best = fmin(best, (now_s() - t0) / reps);
    }
    return best;
}

int main(int argc, char **argv)
{
    int quick = argc > 1 && !strcmp(argv[1], "--quick");
    int w = quick ? 160 : 640, h = quick ? 120 : 480, reps = quick ? 3 : 40;
    long np = (long)w * h;
    chip c;
    if (chip_open(&c))
        return 1;
    uint16_t *raw = malloc(sizeof(uint16_t) * (size_t)np), *out = malloc(sizeof(uint16_t) * (size_t)np);
    for (long i = 0; i < np; i++)
        raw[i] = (uint16_t)(400 + (i * 7919) % 2800);
    size_t big = (size_t)np * (2 + 2 + 8 * 4 + 1) + 4096 + 4 * WDR_CAL_MAX_SHARED_FLOATS; /* + a shared block */
    uint8_t *src = malloc(big), *dst = malloc(big);
    memset(src, 1, big);
    memset(dst, 0, big);
    double t_raw = time_memcpy(dst, src, (size_t)np * 2, reps);
    printf("On-the-fly correction, %dx%d frame, float32 kernel (the firmware's code, built for the host)\n", w, h);
    printf("memcpy of the raw frame (%ld bytes): %.3f ns/pixel\n\n", np * 2, t_raw * 1e9 / np);
    printf("%-34s %6s %10s %12s %14s %12s %12s\n", "table form", "B/px", "ns/pixel", "memcpy raw", "memcpy same B",
           "vs raw", "error %");
    double beyond = 0;
    for (size_t f = 0; f < sizeof forms / sizeof forms[0]; f++) {
        size_t len = 0;
        wdr_cal_view v;
        uint8_t *tb = NULL;
        if (forms[f].form == WDR_FORM_IDENTITY)
            wdr_cal_identity(&v, 1, (uint16_t)w, (uint16_t)h, 16, 4095, 65535);
        else {
            tb = synthetic_table(&forms[f], w, h, &len);
            int rc = wdr_cal_parse(tb, len, &v);
            if (rc) {
                fprintf(stderr, "bench_correct: synthetic %s table refused: %s\n", forms[f].name, wdr_strerror(rc));
                return 1;
            }
            if (per_code(&forms[f], &v))
                return 1;
        }
        size_t streamed = (size_t)np * 4 + (len ? len - WDR_CAL_HEADER_SIZE : 0);
        double t_k = time_kernel(&v, raw, out, reps), t_same = time_memcpy(dst, src, streamed, reps);
        printf("%-34s %6.1f %10.3f %11.2fx %13.2fx %11.2fx %12.4f\n", forms[f].name, (double)streamed / np,
               t_k * 1e9 / np, t_raw / t_k, t_same / t_k, t_k / t_raw, form_error(&c, &forms[f], &beyond));
        free(tb);
    }
    printf("\n'error %%': worst over 31 currents 1e-14..1e-8 A of 100 sd of ln(x_hat/x) on a 64x48 chip, analog\n"
           "(ADC and DAC quantisation off, temporal noise off: the figure holds only so; wdrctl fpn report gives\n"
           "the converters and noise). The identity row is the raw frame through the nominal inverse; up to\n"
           "%.0f %% of its pixels lie past the nominal curve's range there.\n", 100 * beyond);
    printf("\n'memcpy raw' and 'memcpy same B': memcpy time / kernel time (>= 0.5: at least half memcpy's speed)\n"
           "for the raw frame alone, and for the same bytes the kernel streams (raw in, table, out).\n");
    free(raw), free(out), free(src), free(dst);
    wdr_cal_levels_free(&c.grid);
    wdr_sim_destroy(c.sim);
    free(c.lut);
    return 0;
}
