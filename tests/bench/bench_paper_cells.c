/* The paper models' matrix (issue 19, item 2): for every model x operator x mismatch x converters
 * x noise x chip seed, a clean simulated chip calibrated as `wdrctl calibrate --model simple3|complex4`
 * does (tests/calibration/cal_paper_cell.h), and what came of it: refused with the reason, or the
 * healthy pixels flagged (ppm) by reason. No cell may flag more than 10 ppm and be accepted.
 *
 *   bench_paper_cells [--quick] [--board NAME|FILE] [--size WxH] [--seeds 1,2,3] [--mismatch 1,2]
 *                     [--models simple3,complex4] [--ops a,b] [--conv analog,12bit] [--noise on,off]
 *                     [--margin V]
 *
 * Defaults: sim-qvga, seeds 1-3, mismatch 1 and 2, both models, the seven operators, analog and
 * 12 bits, noise on and off. --quick: 48x36, seed 1, mismatch 1, Reinhard and Drago, 12 bits,
 * noise off (seconds). Prints a table and the worst accepted cell; exits 1 when an accepted cell
 * flags more than 10 ppm. */
#include "../calibration/cal_paper_cell.h"
#include "bench_util.h"

#define MAX_LIST 16
#define MAX_PPM 10.0

typedef struct list {
    int n;
    char *s[MAX_LIST];
} list;

static void split(const char *text, list *l)
{
    char *buf = strdup(text), *save = NULL;
    l->n = 0;
    for (char *t = strtok_r(buf, ",", &save); t && l->n < MAX_LIST; t = strtok_r(NULL, ",", &save))
        l->s[l->n++] = strdup(t);
    free(buf);
}

static void list_free(list *l)
{
    for (int i = 0; i < l->n; i++)
        free(l->s[i]);
    l->n = 0;
}

static const char *const all_ops = "reinhard,reinhard_white,schlick,tumblin_rushmeier,drago,exponential,logarithmic";

typedef struct sweep {
    const char *board;
    int width, height;
    double margin_v;
    list seeds, mismatch, models, ops, conv, noise;
} sweep;

static void reasons_text(const paper_cell_result *r, char *buf, size_t cap)
{
    size_t at = 0;
    buf[0] = 0;
    for (int s = 1; s < WDR_FIT_COUNT; s++)
        if (r->by_status[s] && at < cap)
            at += (size_t)snprintf(buf + at, cap - at, "%s%s %ld", at ? ", " : "", wdr_fit_status_name(s),
                                   r->by_status[s]);
    long other = r->flagged;
    for (int s = 1; s < WDR_FIT_COUNT; s++)
        other -= r->by_status[s];
    if (other && at < cap)
        snprintf(buf + at, cap - at, "%sdefect tests %ld", at ? ", " : "", other);
}

static int parse_args(int argc, char **argv, sweep *w)
{
    const char *seeds = "1,2,3", *mm = "1,2", *models = "simple3,complex4", *ops = all_ops, *conv = "analog,12bit",
               *noise = "on,off";
    *w = (sweep){.board = "sim-qvga"};
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : NULL;
        if (!strcmp(a, "--quick")) {
            w->board = NULL, w->width = 48, w->height = 36;
            seeds = "1", mm = "1", ops = "reinhard,drago", conv = "12bit", noise = "off";
            continue;
        }
        if (!v) {
            fprintf(stderr, "bench_paper_cells: %s needs a value\n", a);
            return 1;
        }
        i++;
        if (!strcmp(a, "--board"))
            w->board = v;
        else if (!strcmp(a, "--size") && sscanf(v, "%dx%d", &w->width, &w->height) == 2)
            ;
        else if (!strcmp(a, "--seeds"))
            seeds = v;
        else if (!strcmp(a, "--mismatch"))
            mm = v;
        else if (!strcmp(a, "--models"))
            models = v;
        else if (!strcmp(a, "--ops"))
            ops = v;
        else if (!strcmp(a, "--conv"))
            conv = v;
        else if (!strcmp(a, "--noise"))
            noise = v;
        else if (!strcmp(a, "--margin"))
            w->margin_v = atof(v);
        else {
            fprintf(stderr, "bench_paper_cells: unknown option %s %s\n", a, v);
            return 1;
        }
    }
    split(seeds, &w->seeds), split(mm, &w->mismatch), split(models, &w->models), split(ops, &w->ops);
    split(conv, &w->conv), split(noise, &w->noise);
    return 0;
}

int main(int argc, char **argv)
{
    sweep w;
    if (parse_args(argc, argv, &w))
        return 2;
    printf("# bench_paper_cells: board %s, margin %.0f mV; clean chips (no planted defects)\n",
           w.board ? w.board : "defaults", 1e3 * (w.margin_v > 0 ? w.margin_v : WDR_CAL_MARGIN_V));
    if (w.width)
        printf("# size %dx%d\n", w.width, w.height);
    printf("| model | operator | mismatch | converters | noise | seed | outcome | flagged | ppm | reasons / refusal "
           "| currents (A) | frames | s |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
    double worst_ppm = 0;
    char worst[256] = "none";
    long cells = 0, refused = 0, over = 0;
    for (int im = 0; im < w.models.n; im++)
        for (int io = 0; io < w.ops.n; io++)
            for (int ik = 0; ik < w.mismatch.n; ik++)
                for (int ic = 0; ic < w.conv.n; ic++)
                    for (int in = 0; in < w.noise.n; in++)
                        for (int is = 0; is < w.seeds.n; is++) {
                            paper_cell c = {.board = w.board,
                                            .width = w.width,
                                            .height = w.height,
                                            .mismatch = atof(w.mismatch.s[ik]),
                                            .margin_v = w.margin_v,
                                            .op = w.ops.s[io],
                                            .model = !strcmp(w.models.s[im], "simple3") ? WDR_MODEL_SIMPLE3
                                                                                        : WDR_MODEL_COMPLEX4,
                                            .adc = strcmp(w.conv.s[ic], "analog") != 0,
                                            .noise = !strcmp(w.noise.s[in], "on"),
                                            .seed = strtoull(w.seeds.s[is], NULL, 10)};
                            paper_cell_result r;
                            double t0 = now_s();
                            paper_cell_run(&c, &r);
                            double dt = now_s() - t0, ppm = r.np ? 1e6 * (double)r.flagged / (double)r.np : 0;
                            char why[512], cur[256] = "";
                            if (r.outcome == PAPER_CELL_FITTED)
                                reasons_text(&r, why, sizeof why);
                            else
                                snprintf(why, sizeof why, "%s", r.why);
                            for (int k = 1, at = 0; k < r.choice.n && at < (int)sizeof cur; k++)
                                at += snprintf(cur + at, sizeof cur - (size_t)at, "%s%.3g", k > 1 ? " " : "",
                                               r.choice.amps[k]);
                            printf("| %s | %s | %sx | %s | %s | %s | %s | %ld | %.0f | %s | %s | %d | %.1f |\n",
                                   w.models.s[im], c.op, w.mismatch.s[ik], w.conv.s[ic], w.noise.s[in], w.seeds.s[is],
                                   paper_cell_outcome_name(r.outcome), r.flagged, ppm, why, cur, r.frames, dt);
                            fflush(stdout);
                            cells++;
                            refused += r.outcome != PAPER_CELL_FITTED;
                            if (r.outcome == PAPER_CELL_FITTED && ppm > MAX_PPM)
                                over++;
                            if (r.outcome == PAPER_CELL_FITTED && ppm >= worst_ppm) {
                                worst_ppm = ppm;
                                snprintf(worst, sizeof worst, "%s %s %sx %s noise %s seed %s", w.models.s[im], c.op,
                                         w.mismatch.s[ik], w.conv.s[ic], w.noise.s[in], w.seeds.s[is]);
                            }
                        }
    printf("# %ld cells: %ld refused, %ld accepted; worst accepted %.0f ppm (%s); %ld accepted over %.0f ppm\n", cells,
           refused, cells - refused, worst_ppm, worst, over, MAX_PPM);
    list *lists[] = {&w.seeds, &w.mismatch, &w.models, &w.ops, &w.conv, &w.noise};
    for (size_t k = 0; k < sizeof lists / sizeof lists[0]; k++)
        list_free(lists[k]);
    return over ? 1 : 0;
}
