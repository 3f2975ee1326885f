/* calibrate --form auto: the smallest table form that meets the target on this chip's own frames
 * (host/cal/metrics/cal_form_measure.h), printed with the figure of every smaller form it passed over. */
#include "cal_common.h"
#include "wdr_err.h"
#include <cJSON.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define FORM_AUTO_MAX_FRAMES 4     /* frames averaged per judged current (at most the calibration's) */
#define FORM_AUTO_FRAME_NO 6000000 /* frame numbers apart from the calibration's and the verification's */

/* The calibration's own averaged levels (lit ones only): a real board's light is set by hand. */
static int level_frames(cal_run *r, double *x, float **frames)
{
    cal_form_choice *c = &r->form_auto;
    long np = (long)r->levels.width * r->levels.height;
    c->fresh = 0, c->frames = r->frames, c->currents = 0;
    *frames = malloc(sizeof(float) * (size_t)np * (size_t)r->levels.n);
    if (!*frames)
        return wdrctl_fail(EX_OSERR, "out of memory");
    for (int k = 0; k < r->levels.n; k++)
        if (r->levels.amps[k] > 0) {
            memcpy(*frames + (long)c->currents * np, r->levels.frames + (long)k * np, sizeof(float) * (size_t)np);
            x[c->currents++] = r->levels.amps[k];
        }
    return EX_OK;
}

static void print_trial(const wdr_form_trial *t, const char *verdict)
{
    fprintf(stderr,
            "form auto: %s %s: worst %.3g %% at %.3g A; at %.3g A %.3g %% against %.3g %% allowed (the fit: %.3g %%); "
            "%.1f B/px\n",
            cal_form_name(t->form), verdict, t->worst_pct, t->worst_at, t->excess_at, t->table_pct, t->allowed_pct,
            t->model_pct, t->bytes_px);
}

/* The kept table (the last form tried) becomes the run's, and r->cfg says its form. */
static void adopt(cal_run *r, const wdr_form_trial *t, wdr_form_table *tab)
{
    r->cfg.form = r->res.cfg.form = t->form;
    r->cfg.n_coeffs = r->res.cfg.n_coeffs = t->n_coeffs;
    free(r->table);
    r->table = tab->table, r->table_len = tab->len;
}

static void print_choice(const cal_form_choice *c)
{
    fprintf(stderr,
            "form auto: each form's fixed-pattern error judged at %d currents (%s, %d frames averaged%s) against "
            "max(%.3g %%, %.3gx the fit's own)\n",
            c->currents, c->fresh ? "fresh frames" : "the calibration levels themselves", c->frames,
            c->noise_removed ? ", temporal noise measured and taken out" : "", c->target.analog_pct,
            c->target.floor_ratio);
    for (int k = 0; k < c->tried; k++)
        print_trial(&c->trial[k], k == c->chosen ? "chosen" : "rejected");
    if (c->chosen < 0)
        fprintf(stderr, "form auto: no form meets the target on this chip: basis-8, the most accurate\n");
}

int cal_choose_form(const wdr_cal_source *src, const cal_form_frames_how *how, uint32_t sensor_id, int op_id,
                    cal_run *r)
{
    char err[512];
    cal_form_choice *c = &r->form_auto;
    wdr_form_table tab = {0};
    int can_light = how->can_light, temporal = how->temporal;
    c->target = WDR_FORM_TARGET_DEFAULT;
    if (can_light) {
        c->fresh = 1, c->noise_removed = temporal, c->currents = WDR_FORM_JUDGING_CURRENTS;
        c->frames = r->frames < FORM_AUTO_MAX_FRAMES ? r->frames : FORM_AUTO_MAX_FRAMES;
        wdr_form_judging j = {c->currents, c->frames, temporal, FORM_AUTO_FRAME_NO};
        c->chosen = wdr_form_choose_on_source(&r->res, src, r->lo, r->hi, &j, c->target, sensor_id, op_id, c->trial,
                                              &c->tried, &tab, err, sizeof err);
    } else {
        double x[WDR_CAL_MAX_LEVELS];
        float *frames = NULL;
        int rc = level_frames(r, x, &frames);
        wdr_form_frames f = {frames, NULL, x, c->currents};
        if (rc != EX_OK)
            return rc;
        c->chosen = wdr_form_choose_measured(&r->res, &f, c->target, sensor_id, op_id, c->trial, &c->tried, &tab, err,
                                             sizeof err);
        free(frames);
    }
    if (c->chosen == -2)
        return wdrctl_fail(EX_SOFTWARE, "calibrate: form auto: %s", err);
    print_choice(c);
    adopt(r, &c->trial[c->chosen < 0 ? c->tried - 1 : c->chosen], &tab);
    return EX_OK;
}

/* One tried form's figures (the same as printed). */
static cJSON *trial_json(const wdr_form_trial *t, int chosen)
{
    cJSON *j = cJSON_CreateObject();
    cJSON_AddStringToObject(j, "form", cal_form_name(t->form));
    cJSON_AddNumberToObject(j, "coefficients", t->n_coeffs);
    cJSON_AddNumberToObject(j, "bytes_per_pixel", t->bytes_px);
    cJSON_AddNumberToObject(j, "worst_pct", t->worst_pct);
    cJSON_AddNumberToObject(j, "worst_at_A", t->worst_at);
    cJSON_AddNumberToObject(j, "worst_over_allowed", t->excess);
    cJSON_AddNumberToObject(j, "deciding_at_A", t->excess_at);
    cJSON_AddNumberToObject(j, "deciding_table_pct", t->table_pct);
    cJSON_AddNumberToObject(j, "deciding_fit_pct", t->model_pct);
    cJSON_AddNumberToObject(j, "deciding_allowed_pct", t->allowed_pct);
    cJSON_AddBoolToObject(j, "meets", t->meets);
    cJSON_AddBoolToObject(j, "chosen", chosen);
    return j;
}

cJSON *cal_form_choice_json(const cal_form_choice *c)
{
    cJSON *j = cJSON_CreateObject();
    cJSON_AddNumberToObject(j, "target_pct", c->target.analog_pct);
    cJSON_AddNumberToObject(j, "fit_ratio", c->target.floor_ratio);
    cJSON_AddNumberToObject(j, "judged_currents", c->currents);
    cJSON_AddNumberToObject(j, "frames_averaged", c->frames);
    cJSON_AddStringToObject(j, "frames", c->fresh ? "fresh" : "the calibration levels");
    cJSON_AddBoolToObject(j, "temporal_noise_taken_out", c->noise_removed);
    cJSON_AddBoolToObject(j, "none_met", c->chosen < 0);
    cJSON *a = cJSON_AddArrayToObject(j, "tried");
    for (int k = 0; k < c->tried; k++)
        cJSON_AddItemToArray(a, trial_json(&c->trial[k], k == (c->chosen < 0 ? c->tried - 1 : c->chosen)));
    cJSON_AddStringToObject(j, "note",
                            "each form's table built from the one fit and judged against the fit's own model on the "
                            "same frames; allowed = max(target_pct, fit_ratio x the fit's own error), at every "
                            "judged current; the smallest that meets is chosen, basis-8 when none does");
    return j;
}
