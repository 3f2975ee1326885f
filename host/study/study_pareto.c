/* Pareto fronts of the study's accuracy figures against its costs, and the cheapest point that
 * meets a target. Lower is better on both axes. */
#include "study.h"
#include <math.h>
#include <stdlib.h>

static const char *const acc_names[] = {"worst_total_pct", "worst_fpn_pct", "floor_pct", "display_levels"};
static const char *const acc_units[] = {"%", "%", "%", "8-bit levels"};
static const char *const cost_names[] = {"image_time_s",         "calibration_time_s",  "table_bytes_per_pixel",
                                         "table_bandwidth_Bps",  "correct_ns_per_pixel", "fit_s_per_megapixel",
                                         "m7_instructions_per_pixel"};
static const char *const cost_units[] = {"s", "s", "B/pixel", "B/s", "ns/pixel", "s/Mpixel", "insn/pixel"};
/* frame, calibration and bandwidth follow from the board; table bytes from the format (the
 * half-precision sizes modelled); the correction kernel and the fit are timed here */
static const int cost_measured[] = {0, 0, 0, 0, 1, 1, 1}; /* M7: measured by bench_target (study_m7.c) */

const char *study_acc_name(int a)
{
    return acc_names[a];
}
const char *study_acc_unit(int a)
{
    return acc_units[a];
}
const char *study_cost_name(int c)
{
    return cost_names[c];
}
const char *study_cost_unit(int c)
{
    return cost_units[c];
}
int study_cost_measured(int c)
{
    return cost_measured[c];
}

double study_acc_value(const study_result *r, int a)
{
    const double v[] = {r->worst_total_pct, r->worst_fpn_pct, r->floor_pct, r->display_levels};
    return v[a];
}

double study_cost_value(const study_result *r, int c)
{
    const double v[] = {r->image_s,       r->cal_s,        r->table_bpp,  r->bandwidth_Bps,
                        r->correct_ns_px, r->fit_s_per_mp, r->m7_instr_px};
    return v[c];
}

static const study *sort_study; /* qsort has no context argument */
static int sort_acc, sort_cost;

static int by_cost(const void *pa, const void *pb)
{
    const study_result *a = &sort_study->res[*(const int *)pa], *b = &sort_study->res[*(const int *)pb];
    double ca = study_cost_value(a, sort_cost), cb = study_cost_value(b, sort_cost);
    if (ca != cb)
        return ca < cb ? -1 : 1;
    double aa = study_acc_value(a, sort_acc), ab = study_acc_value(b, sort_acc);
    return aa < ab ? -1 : aa > ab;
}

int study_front(const study *s, int a, int c, int *idx)
{
    int n = 0, m = 0;
    for (int i = 0; i < s->n; i++)
        if (s->res[i].ok && isfinite(study_acc_value(&s->res[i], a)) && isfinite(study_cost_value(&s->res[i], c)))
            idx[n++] = i;
    sort_study = s, sort_acc = a, sort_cost = c;
    qsort(idx, (size_t)n, sizeof *idx, by_cost);
    double best = INFINITY;
    for (int k = 0; k < n; k++) { /* cheapest first: keep a point only if it is more accurate */
        double v = study_acc_value(&s->res[idx[k]], a);
        if (v < best)
            best = v, idx[m++] = idx[k];
    }
    return m;
}

int study_cheapest(const study *s, int a, int c, double target_pct)
{
    int best = -1;
    for (int i = 0; i < s->n; i++) {
        const study_result *r = &s->res[i];
        double ci = study_cost_value(r, c);
        if (!r->ok || !r->bus_feeds || !(study_acc_value(r, a) <= target_pct) || !isfinite(ci))
            continue; /* a design the board's memory bus cannot feed at the frame rate is no answer */
        if (best < 0 || ci < study_cost_value(&s->res[best], c) ||
            (ci == study_cost_value(&s->res[best], c) && study_acc_value(r, a) < study_acc_value(&s->res[best], a)))
            best = i;
    }
    return best;
}
