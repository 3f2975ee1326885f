/* The LUT's exposure table anchored at the calibration's levels (host/cal/table/cal_exposure.h).
 * A chip whose median pixel answers a current x with the code the table gives x e^s(x), with s a
 * planted offset of 0.08 ln at 1e-14 A falling to 0 at 1e-12 A (sim-qvga's seed 5 showed 0.02-0.12
 * ln there), and, in a second case, 0.04 ln over the whole range. Before anchoring the table reads
 * each level's median code about s high; after it, at every calibration level on the table's
 * sloped part, within 1.5/256 ln (the table's rounding), and halfway between levels (in ln I)
 * within 3/256 ln and a quarter of the error summed over those points before. The floor and the ceiling stay in the
 * same bins, the flat ends stay flat, and a LUT without an exposure block is left byte for byte.
 * Schlick (WDR_LUT_EXPO_LINEAR_DARK): the line past the floor that the firmware reads the dark tail
 * from follows the chip's mean codes at the levels past the floor (check_dark_line). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <cmocka.h>
#include "cal_exposure.h"
#include "cal_fit.h"
#include "ramp.h"
#include "wdr_err.h"
#include "wdr_lut.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

#define LEVELS 16
#define KNOTS 61 /* the nominal's knots, 10 per decade over 1e-14..1e-8 */

typedef struct rig {
    wdr_board b;
    uint8_t *lut;
    size_t len;
    double key;
    wdr_nominal nom;
    double amps[LEVELS];
} rig;

typedef double (*offset_fn)(double x);

static double dark_end_offset(double x)
{
    return 0.08 * fmax(0, log(1e-12 / x)) / log(100.0);
}

static double flat_offset(double x)
{
    (void)x;
    return 0.04;
}

static double table_ln(const wdr_lut_exposure *ex, double code);
static const wdr_lut_exposure *block(const rig *r, wdr_lut_exposure *ex);

/* The code the table gives ln(x / key) - s: its sloped part falls as the code rises; bisection. */
static double code_of(const wdr_lut_exposure *ex, double ln_rel)
{
    double lo = 0, hi = (double)((uint32_t)ex->bins << ex->code_shift);
    for (int i = 0; i < 60; i++) {
        double mid = 0.5 * (lo + hi);
        *(table_ln(ex, mid) > ln_rel ? &lo : &hi) = mid;
    }
    return 0.5 * (lo + hi);
}

/* A chip of the board's design (the exposure table as built) whose median pixel answers a current x
 * with the code the design gives x e^s(x). */
static void rig_open_op(rig *r, offset_fn s, const char *op)
{
    char err[512];
    memset(r, 0, sizeof *r);
    wdr_board_defaults(&r->b);
    r->b.width = 160, r->b.height = 120;
    r->key = 0.18 * r->b.i_center_a;
    assert_int_equal(wdr_ramp_board_lut(&r->b, op, &r->lut, &r->len, NULL, err, sizeof err), WDR_OK);
    assert_int_equal(wdr_ramp_lut_append_exposure(&r->lut, &r->len, &r->b, r->key), WDR_OK);
    wdr_lut_exposure *ex = malloc(sizeof *ex);
    assert_non_null(ex);
    block(r, ex);
    double lx[KNOTS], y[KNOTS];
    for (int k = 0; k < KNOTS; k++) {
        lx[k] = log(1e-14) + k * log(1e6) / (KNOTS - 1);
        y[k] = code_of(ex, lx[k] + s(exp(lx[k])) - log(r->key));
    }
    free(ex);
    r->nom.model = WDR_MODEL_SPLINE;
    r->nom.x_lo = 1e-14, r->nom.x_hi = 1e-8;
    assert_int_equal(wdr_pchip_init(&r->nom.curve, lx, y, KNOTS), WDR_OK);
    for (int k = 0; k < LEVELS; k++)
        r->amps[k] = 1e-14 * pow(1e6, k / (LEVELS - 1.0));
}

static void rig_open(rig *r, offset_fn s)
{
    rig_open_op(r, s, "reinhard");
}

static void rig_close(rig *r)
{
    free(r->lut);
}

static const wdr_lut_exposure *block(const rig *r, wdr_lut_exposure *ex)
{
    wdr_lut_view v;
    assert_int_equal(wdr_lut_parse(r->lut, r->len, &v), WDR_OK);
    size_t end = wdr_lut_size(v.h.entry_count);
    assert_int_equal(wdr_lut_exposure_parse(r->lut + end, r->len - end, ex), WDR_OK);
    return ex;
}

/* The table at a code, as the firmware reads it, in ln units. */
static double table_ln(const wdr_lut_exposure *ex, double code)
{
    double u = fmax(code, 0) / (1u << ex->code_shift);
    uint32_t bin = (uint32_t)u;
    if (bin >= ex->bins - 1u)
        return ex->ln_q8[ex->bins - 1u] / 256.0;
    return (ex->ln_q8[bin] + (u - bin) * (ex->ln_q8[bin + 1u] - ex->ln_q8[bin])) / 256.0;
}

/* What the table says of current x's median code, less the truth (ln). */
static double reading_error(const rig *r, const wdr_lut_exposure *ex, double x)
{
    return table_ln(ex, wdr_nominal_eval(&r->nom, x)) - log(x / r->key);
}

static void limits(const wdr_lut_exposure *ex, uint32_t *first_min, uint32_t *last_max)
{
    *first_min = *last_max = 0;
    for (uint32_t k = 1; k < ex->bins; k++) {
        if (ex->ln_q8[k] < ex->ln_q8[*first_min])
            *first_min = k;
        if (ex->ln_q8[k] >= ex->ln_q8[0])
            *last_max = k;
    }
}

/* On the sloped part the firmware reads: the code lies between the ceiling's bin and the floor's
 * code (WDR_LUT_EXPO_FLOOR_CODE less half a code: codes from there on are censored). */
static int sloped(const wdr_lut_exposure *ex, double code)
{
    uint32_t fmin_, lmax;
    limits(ex, &fmin_, &lmax);
    return code >= (double)((lmax + 1u) << ex->code_shift) &&
           code <= WDR_LUT_EXPO_FLOOR_CODE(fmin_, ex->code_shift) - 0.5;
}

static void check_anchored(offset_fn s, const char *what)
{
    rig r;
    rig_open(&r, s);
    wdr_lut_exposure *before = malloc(sizeof *before), *after = malloc(sizeof *after);
    block(&r, before);
    wdr_cal_exposure_anchors a;
    assert_int_equal(wdr_cal_exposure_anchor(r.lut, r.len, &r.b, &r.nom, 1.0, r.amps, LEVELS, NULL, &a), WDR_OK);
    block(&r, after);
    print_message("%s: %d levels anchored, largest move %.3f ln at %.3g A\n", what, a.n, a.worst_ln, a.worst_at_a);
    assert_true(a.n >= LEVELS - 3);
    int on_slope = 0;
    double sum0 = 0, sum1 = 0; /* |error| halfway between levels, before and after */
    for (int k = 0; k < LEVELS; k++) {
        double c = wdr_nominal_eval(&r.nom, r.amps[k]);
        if (!sloped(before, c))
            continue;
        on_slope++;
        double e0 = reading_error(&r, before, r.amps[k]), e1 = reading_error(&r, after, r.amps[k]);
        print_message("  level %.3g A: error %+.4f -> %+.4f ln\n", r.amps[k], e0, e1);
        assert_true(fabs(e1) <= 1.5 / 256);
        if (k + 1 < LEVELS && sloped(before, wdr_nominal_eval(&r.nom, r.amps[k + 1]))) {
            double mid = sqrt(r.amps[k] * r.amps[k + 1]);
            double m0 = reading_error(&r, before, mid), m1 = reading_error(&r, after, mid);
            print_message("    halfway %.3g A: %+.4f -> %+.4f ln\n", mid, m0, m1);
            assert_true(fabs(m1) <= 3.0 / 256);
            sum0 += fabs(m0), sum1 += fabs(m1);
        }
    }
    assert_int_equal(on_slope, a.n);
    assert_true(sum1 <= 0.25 * sum0);
    uint32_t f0, l0, f1, l1;
    limits(before, &f0, &l0);
    limits(after, &f1, &l1);
    assert_int_equal(f0, f1);
    assert_int_equal(l0, l1);
    for (uint32_t k = f1; k < after->bins; k++)
        assert_int_equal(after->ln_q8[k], after->ln_q8[f1]);
    for (uint32_t k = 0; k <= l1; k++)
        assert_int_equal(after->ln_q8[k], after->ln_q8[0]);
    for (uint32_t k = 1; k < after->bins; k++)
        assert_true(after->ln_q8[k] <= after->ln_q8[k - 1]);
    free(before);
    free(after);
    rig_close(&r);
}

static void dark_end_offset_is_taken_out(void **state)
{
    (void)state;
    check_anchored(dark_end_offset, "0.08 ln at 1e-14 A, none from 1e-12 A");
}

static void flat_offset_is_taken_out(void **state)
{
    (void)state;
    check_anchored(flat_offset, "0.04 ln everywhere");
}

static void lut_without_block_is_left_alone(void **state)
{
    (void)state;
    rig r;
    char err[256];
    rig_open(&r, flat_offset);
    uint8_t *plain;
    size_t len;
    assert_int_equal(wdr_ramp_board_lut(&r.b, "reinhard", &plain, &len, NULL, err, sizeof err), WDR_OK);
    uint8_t *copy = malloc(len);
    memcpy(copy, plain, len);
    wdr_cal_exposure_anchors a;
    assert_int_equal(wdr_cal_exposure_anchor(plain, len, &r.b, &r.nom, 1.0, r.amps, LEVELS, NULL, &a), WDR_OK);
    assert_int_equal(a.n, 0);
    assert_memory_equal(plain, copy, len);
    free(plain);
    free(copy);
    rig_close(&r);
}

/* The line past the floor as fw_expo.c's dark_tail_from_codes reads it: bin b0 of the floor's code
 * and b1, the floor's flat run; the code of a current e^ln_rel (ln against the key). */
static double line_code(const wdr_lut_exposure *ex, double ln_rel)
{
    uint32_t b1, last_max;
    limits(ex, &b1, &last_max);
    double floor_code = WDR_LUT_EXPO_FLOOR_CODE(b1, ex->code_shift) - 0.5;
    uint32_t b0 = (uint32_t)floor_code >> ex->code_shift;
    double l0 = ex->ln_q8[b0] / 256.0, drop = 1 - exp(ex->ln_q8[b1] / 256.0 - l0);
    return (double)(b0 << ex->code_shift) + (1 - exp(ln_rel - l0)) * (double)((b1 - b0) << ex->code_shift) / drop;
}

/* A Schlick chip (its dark end linear in current: WDR_LUT_EXPO_LINEAR_DARK) whose mean codes past
 * the floor lie off the design's line: by `off` at no light, falling linearly in current to 0 at
 * the floor's bin (turned: the line can follow it), or by `off` at every level past the floor
 * (shifted: a line turned about b0 can only split it). After anchoring, turned: the line reads
 * each of those levels' codes within 0.05 code (before: `off` (1 - I / I_b0)) and its end moved by
 * `off` within 0.05; shifted: the summed error at least halved. Both: the floor stays in its bin
 * and the sloped part is what the sloped anchors alone make it. */
static double no_offset(double x)
{
    (void)x;
    return 0;
}

static void check_dark_line(double off, int turned)
{
    rig r;
    rig_open_op(&r, no_offset, "schlick");
    wdr_lut_exposure *before = malloc(sizeof *before), *after = malloc(sizeof *after),
                     *sloped_only = malloc(sizeof *sloped_only);
    block(&r, before);
    assert_true(before->flags & WDR_LUT_EXPO_LINEAR_DARK);
    uint32_t f0, l0, f1, l1;
    limits(before, &f0, &l0);
    double floor_code = WDR_LUT_EXPO_FLOOR_CODE(f0, before->code_shift) - 0.5, codes[LEVELS];
    int past = 0;
    uint8_t *copy = malloc(r.len);
    memcpy(copy, r.lut, r.len);
    wdr_cal_exposure_anchors a;
    assert_int_equal(wdr_cal_exposure_anchor(copy, r.len, &r.b, &r.nom, 1.0, r.amps, LEVELS, NULL, &a), WDR_OK);
    uint8_t *keep = r.lut;
    r.lut = copy;
    block(&r, sloped_only);
    r.lut = keep;
    free(copy);
    for (int k = 0; k < LEVELS; k++) {
        double ln_rel = log(r.amps[k] / r.key), c = line_code(sloped_only, ln_rel);
        codes[k] = wdr_nominal_eval(&r.nom, r.amps[k]);
        if (codes[k] > floor_code && c > floor_code) /* past the floor: the chip's codes are the line's + off */
            codes[k] =
                c + off * (turned ? 1 - exp(ln_rel -
                                            sloped_only->ln_q8[(uint32_t)floor_code >> sloped_only->code_shift] / 256.0)
                                  : 1),
            past++;
    }
    assert_true(past >= 2);
    assert_int_equal(wdr_cal_exposure_anchor(r.lut, r.len, &r.b, &r.nom, 1.0, r.amps, LEVELS, codes, &a), WDR_OK);
    block(&r, after);
    print_message("schlick, codes past the floor %+.2f off the line (%s): %d levels there, its end moved %+.3f codes\n",
                  off, turned ? "turned" : "shifted", past, a.dark_moved_codes);
    assert_true(a.dark_line);
    double sum0 = 0, sum1 = 0;
    for (int k = 0; k < LEVELS; k++) {
        double ln_rel = log(r.amps[k] / r.key);
        if (!(codes[k] > floor_code))
            continue;
        double c0 = line_code(sloped_only, ln_rel), c1 = line_code(after, ln_rel);
        print_message("  level %.3g A: line %.3f -> %.3f, chip %.3f\n", r.amps[k], c0, c1, codes[k]);
        sum0 += fabs(c0 - codes[k]), sum1 += fabs(c1 - codes[k]);
        assert_true(!turned || fabs(c1 - codes[k]) <= 0.05);
    }
    assert_true(sum0 > 0.5 * fabs(off));
    assert_true(sum1 <= 0.5 * sum0);
    assert_true(!turned || fabs(a.dark_moved_codes - off) <= 0.05);
    limits(after, &f1, &l1);
    assert_int_equal(f0, f1);
    assert_int_equal(l0, l1);
    for (uint32_t k = 0; k < f1; k++)
        assert_int_equal(after->ln_q8[k], sloped_only->ln_q8[k]);
    for (uint32_t k = f1; k < after->bins; k++)
        assert_int_equal(after->ln_q8[k], after->ln_q8[f1]);
    free(before);
    free(after);
    free(sloped_only);
    rig_close(&r);
}

static void dark_line_turns_to_the_chip(void **state)
{
    (void)state;
    check_dark_line(0.4, 1);
    check_dark_line(-0.3, 1);
}

static void dark_line_splits_a_shift(void **state)
{
    (void)state;
    check_dark_line(0.4, 0);
    check_dark_line(-0.3, 0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(dark_end_offset_is_taken_out),    cmocka_unit_test(flat_offset_is_taken_out),
        cmocka_unit_test(lut_without_block_is_left_alone), cmocka_unit_test(dark_line_turns_to_the_chip),
        cmocka_unit_test(dark_line_splits_a_shift),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
