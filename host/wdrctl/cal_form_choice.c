/* calibrate --form auto: the smallest table form that meets the target on this chip's own frames
 * (host/cal/metrics/cal_form_measure.h), printed with the figure of every smaller form it passed over.
 * A board that cannot light itself is judged the same way, a person setting each judged current.
 * Two cheaper rules were tried on sim-qvga (seed 1, Reinhard, 2 and 8 frames per level) and both
 * gave basis-8 there: the forms judged in-sample on the calibration levels (the fit
 * passes through its levels, 0 %, so each form's own departure there, 17-30 % at the top level,
 * failed the 1 % floor), and on the codes the fit itself predicts (a form departs 12-20 % from the
 * fit at the range's ends, where the fit is as far from the truth). tests/e2e/cli_calibrate_by_hand.sh. */
#include "cal_common.h"
#include "wdr_err.h"
#include <cJSON.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define FORM_AUTO_MAX_FRAMES 4     /* frames averaged per judged current (at most the calibration's) */
#define FORM_AUTO_FRAME_NO 6000000 /* frame numbers apart from the calibration's and the verification's */

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
            "form auto: each form's fixed-pattern error judged at %d currents (fresh frames, %d frames averaged%s) "
            "against max(%.3g %%, %.3gx the fit's own)\n",
            c->currents, c->frames, c->noise_removed ? ", temporal noise measured and taken out" : "",
            c->target.analog_pct, c->target.floor_ratio);
    for (int k = 0; k < c->tried; k++)
        print_trial(&c->trial[k], k == c->chosen ? "chosen" : "rejected");
    if (c->chosen < 0) {
        const wdr_form_trial *t = &c->trial[wdr_form_nearest(c->trial, c->tried)];
        fprintf(stderr, "form auto: no form meets the target on this chip: %s kept, the nearest to it (%.3gx its allowance)\n",
                cal_form_name(t->form), t->excess);
    }
}

int cal_choose_form(const wdr_cal_source *src, const cal_form_frames_how *how, uint32_t sensor_id, int op_id,
                    cal_run *r)
{
    char err[512];
    cal_form_choice *c = &r->form_auto;
    wdr_form_table tab = {0};
    c->target = WDR_FORM_TARGET_DEFAULT;
    c->noise_removed = how->temporal, c->currents = WDR_FORM_JUDGING_CURRENTS;
    c->frames = r->frames < FORM_AUTO_MAX_FRAMES ? r->frames : FORM_AUTO_MAX_FRAMES;
    if (!how->can_light)
        fprintf(stderr,
                "form auto: judging the table forms takes %d more lights, from %.3g to %.3g A (--form NAME skips "
                "this)\n",
                c->currents, r->lo, r->hi);
    wdr_form_judging j = {c->currents, c->frames, how->temporal, FORM_AUTO_FRAME_NO};
    c->chosen = wdr_form_choose_on_source(&r->res, src, r->lo, r->hi, &j, c->target, sensor_id, op_id, c->trial,
                                          &c->tried, &tab, err, sizeof err);
    if (c->chosen == -2)
        return wdrctl_fail(EX_SOFTWARE, "calibrate: form auto: %s", err);
    print_choice(c);
    adopt(r, &c->trial[c->chosen < 0 ? wdr_form_nearest(c->trial, c->tried) : c->chosen], &tab);
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
    cJSON_AddStringToObject(j, "frames", "fresh");
    cJSON_AddBoolToObject(j, "temporal_noise_taken_out", c->noise_removed);
    cJSON_AddBoolToObject(j, "none_met", c->chosen < 0);
    cJSON *a = cJSON_AddArrayToObject(j, "tried");
    for (int k = 0; k < c->tried; k++)
        cJSON_AddItemToArray(a, trial_json(&c->trial[k], k == (c->chosen < 0 ? wdr_form_nearest(c->trial, c->tried) : c->chosen)));
    cJSON_AddStringToObject(j, "note",
                            "each form's table built from the one fit and judged against the fit's own model on the "
                            "same frames; allowed = max(target_pct, fit_ratio x the fit's own error), at every "
                            "judged current; the smallest that meets is chosen, the nearest to its allowance when none does");
    return j;
}
