/* Each table form at 12 bits against its floor: the worst over 31 currents of the table's contrast
 * error with the ADC and DAC on (temporal noise off) over sqrt(analog^2 + quantisation floor^2),
 * the measure test_cal_endslope holds the default table to (1.2x) and the matrix holds
 * `--form auto`'s choice to. 64x48 chip, seed 11, the operator's ramp, spline through 19 levels, the same fit for
 * every form (one per chip and condition).
 *
 *   bench_floor [--quick] [--ops reinhard,drago,...]      (--quick: Reinhard, compact only) */
#include "cal_design.h"
#include "cal_select.h"
#include "wdr_err.h"
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define W 64
#define H 48
#define N_TEST 31

typedef struct chip {
    wdr_board b;
    wdr_sim *sim;
    uint8_t *lut;
    wdr_cal_simsrc ss;
    wdr_cal_source src;
    wdr_cal_levels grid;
    wdr_cal_design design;
} chip;

static int chip_open(chip *c, const char *op, int converters)
{
    char err[512];
    wdr_board_defaults(&c->b);
    c->b.width = W, c->b.height = H;
    if (wdr_cal_sim_setup(&c->b, op, 11, converters, WDR_CAL_MARGIN_V, &c->sim, &c->lut, err, sizeof err))
        return fprintf(stderr, "bench_floor: %s\n", err), 1;
    if (!converters)
        wdr_sim_set_effect(c->sim, WDR_FX_DAC_QUANT, WDR_FX_OFF);
    c->ss = (wdr_cal_simsrc){c->sim, converters, 500};
    c->src = (wdr_cal_source){W, H, wdr_cal_sim_capture, &c->ss};
    double amps[37];
    const int middle_row = H / 2; /* the row whose hold time the design assumes */
    for (int k = 0; k < 37; k++)
        amps[k] = 1e-14 * pow(10, k / 6.0);
    if (wdr_cal_acquire(&c->src, amps, 37, 1, 1, NULL, NULL, &c->grid, err, sizeof err) ||
        wdr_cal_design_init(&c->design, &c->b, op, wdr_sim_integration_time(c->sim), middle_row * c->b.row_time_s, 1,
                            err, sizeof err))
        return fprintf(stderr, "bench_floor: %s: %s\n", op, err), 1;
    return 0;
}

static void chip_close(chip *c)
{
    wdr_cal_levels_free(&c->grid);
    wdr_sim_destroy(c->sim);
    free(c->lut);
}

static int fit(chip *c, double lo, double hi, wdr_cal_result *res)
{
    char err[512];
    wdr_cal_config cfg;
    wdr_cal_choice ch;
    wdr_cal_levels lv;
    wdr_cal_config_defaults(&cfg, WDR_MODEL_SPLINE);
    cfg.range_lo = lo, cfg.range_hi = hi;
    cfg.tie_codes = c->ss.quantised ? cfg.tie_codes : 1e-3;
    cfg.design = &c->design;
    if (wdr_cal_select_currents(&c->grid, &cfg, 19, lo, hi, 256, &ch, err, sizeof err) ||
        wdr_cal_levels_from_choice(&c->grid, &ch, &lv))
        return fprintf(stderr, "bench_floor: select: %s\n", err), 1;
    int rc = wdr_cal_fit_array(&lv, &cfg, res, err, sizeof err);
    lv.dark = NULL;
    wdr_cal_levels_free(&lv);
    return rc ? (fprintf(stderr, "bench_floor: fit: %s\n", err), 1) : 0;
}

/* Contrast error per current of a form/n table built from res. */
static int judge(chip *c, const wdr_cal_result *res, int form, int n, const double *x, double *pct)
{
    char err[512];
    uint8_t *tb;
    size_t tl;
    wdr_cal_view tab;
    wdr_cal_result alt = *res;
    alt.cfg.form = form, alt.cfg.n_coeffs = n;
    if (wdr_cal_build_table(&alt, 1, 1, &tb, &tl, err, sizeof err) || wdr_cal_parse(tb, tl, &tab))
        return fprintf(stderr, "bench_floor: table: %s\n", err), 1;
    wdr_eval_opts eo = {.frames = 1, .quantised = c->ss.quantised, .design = &c->design};
    for (int k = 0; k < N_TEST; k++) {
        wdr_eval_point p;
        eo.first_frame_no = 9000 + k;
        if (wdr_eval_point_measure(res, &tab, &c->src, x[k], &eo, &p))
            return free(tb), 1;
        pct[k] = p.table.sd_pct;
    }
    free(tb);
    return 0;
}

int main(int argc, char **argv)
{
    static const char *const all[] = {"reinhard", "reinhard_white", "schlick",    "tumblin_rushmeier",
                                      "drago",    "exponential",    "logarithmic"};
    static const struct {
        const char *name;
        int form, n;
    } forms[] = {{"compact", WDR_FORM_COMPACT, 4},
                 {"shifted", WDR_FORM_SHIFTED, 4},
                 {"poly-5", WDR_FORM_POLY, 5},
                 {"basis-8", WDR_FORM_BASIS, 8}};
    const char *ops = "reinhard";
    int quick = 0;
    for (int i = 1; i < argc; i++)
        if (!strcmp(argv[i], "--quick"))
            quick = 1;
        else if (i + 1 < argc && !strcmp(argv[i], "--ops"))
            ops = argv[++i];
        else
            return fprintf(stderr, "bench_floor: unknown argument '%s'\n", argv[i]), 64;
    printf("bench_floor: worst 12-bit table error over its floor sqrt(analog^2 + quantisation^2)\n");
    for (size_t o = 0; o < sizeof all / sizeof all[0]; o++) {
        if (!strstr(ops, all[o]) || (strstr(all[o], "reinhard_") && !strstr(ops, "reinhard_")))
            continue;
        chip an, q;
        wdr_cal_result ra, rq;
        double lo, hi, x[N_TEST];
        if (chip_open(&an, all[o], 0) || chip_open(&q, all[o], 1) ||
            wdr_cal_informative_range(&an.grid, 2.0, &lo, &hi) || fit(&an, lo, hi, &ra) || fit(&q, lo, hi, &rq))
            return 1;
        for (int k = 0; k < N_TEST; k++)
            x[k] = lo * pow(hi / lo, (k + 0.37) / N_TEST);
        printf("  %-18s", all[o]);
        for (size_t f = 0; f < (quick ? 1 : sizeof forms / sizeof forms[0]); f++) {
            double a[N_TEST], e[N_TEST], worst = 0, worst_a = 0;
            if (judge(&an, &ra, forms[f].form, forms[f].n, x, a) || judge(&q, &rq, forms[f].form, forms[f].n, x, e))
                return 1;
            for (int k = 0; k < N_TEST; k++) {
                double qf = wdr_quant_floor_pct(wdr_cal_design_log_slope(&q.design, x[k]),
                                                wdr_cal_design_dac_step_codes(&q.design, x[k]));
                worst = fmax(worst, e[k] / hypot(a[k], qf));
                worst_a = fmax(worst_a, a[k]);
            }
            printf("  %s %.3fx (analog %.3f %%)", forms[f].name, worst, worst_a);
            fflush(stdout);
        }
        printf("\n");
        wdr_cal_result_free(&ra), wdr_cal_result_free(&rq);
        chip_close(&an), chip_close(&q);
    }
    return 0;
}
