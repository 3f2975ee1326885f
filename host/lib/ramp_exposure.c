/* The exposure table that comes with a LUT (LUT 1.1, firmware/SPEC.md): for each bin of corrected
 * codes, ln(I / I_key) of the current whose nominal-pixel code is the bin's first code. The firmware
 * averages it over a frame for the scene's log-average against the key. */
#include "ramp.h"
#include "wdr_err.h"
#include <math.h>
#include <stdbool.h>
#include <stdlib.h>
#include <string.h>

/* A LUT with its steps worked out once: a table evaluates the nominal pixel at some 10,000
 * currents, and building the steps for each (two pow() per LUT entry) was the auto-exposure
 * run's largest cost. */
typedef struct expo_lut {
    const wdr_lut_view *view;
    wdr_lut_steps steps;
} expo_lut;

/* The hold droop until the middle row is read. The calibration's corrected codes are the array
 * median's, whose pixels wait half the readout after the ramp (4.8 ms on sim-vga, three times the
 * integration: 1.6 codes, 0.2-0.5 ln each at the ends of Reinhard's response). */
static double read_droop_v(const wdr_board *b)
{
    return b->hold_leak_a / b->c_hold_f * 0.5 * (b->height > 0 ? b->height - 1 : 0) * b->row_time_s;
}

/* The nominal pixel's G at the middle row's read, with light i, as the calibration's design maps
 * corrected codes (host/cal/fit/cal_design.c): the ramp sees the light plus the board's dark
 * current, and G droops from the crossing to the integration's end, then for the read delay.
 * Without the first droop the table read sim-qvga's brightest 1.1 ln 0.19 ln bright (about 0.6
 * code, where one code spans 0.1-0.3 ln). *own_droop gets that droop (V). */
static double held_g(const wdr_ideal_pixel *px, const wdr_board *b, const expo_lut *lut, double i,
                     double *own_droop)
{
    double total = i + b->dark_current_a, g = wdr_lut_steps_response(px, &lut->steps, total);
    double t_end = (double)lut->view->h.t_integration_ticks * lut->view->h.tick_ps * 1e-12;
    double t_c = fmin(wdr_ideal_cross_time(px, total, g), t_end);
    *own_droop = b->hold_leak_a * (t_end - (t_c > 0 ? t_c : 0)) / b->c_hold_f;
    return g - *own_droop - read_droop_v(b);
}

static double codes_per_volt(const wdr_board *b)
{
    return b->adc_gain / (b->adc_hi_v - b->adc_lo_v) * ((1u << b->adc_bits) - 1u);
}

/* Unrounded ADC code of the nominal pixel with light i under lut, read at the middle row. */
static double ideal_code(const wdr_ideal_pixel *px, const wdr_board *b, const expo_lut *lut, double i)
{
    double dv, v = wdr_pixel_sf_out(&px->dev, held_g(px, b, lut, i, &dv));
    return (b->adc_offset_v - b->adc_lo_v) / (b->adc_hi_v - b->adc_lo_v) * ((1u << b->adc_bits) - 1u) +
           codes_per_volt(b) * v;
}

/* Codes the hold droop takes from code `code` per unit of (tick / own tick - 1): a pixel that
 * crossed at t_c holds G for (T - t_c) m + the row's read delay at tick ratio m; the read delay and
 * the own tick's droop are in the calibration's nominal response, the rest is (m - 1) (T - t_c). */
static double droop_codes(const wdr_ideal_pixel *px, const wdr_board *b, const expo_lut *lut, double ln_i)
{
    double dv, g = held_g(px, b, lut, exp(ln_i), &dv);
    return codes_per_volt(b) * (wdr_pixel_sf_out(&px->dev, g) - wdr_pixel_sf_out(&px->dev, g - dv));
}

/* A bin's droop per unit of (tick / own tick - 1), in 1/256 code, at the current ln_i of its
 * first code, from the LUT's own integration time. */
static int16_t droop_q8_at(const wdr_ideal_pixel *px, const wdr_board *b, const expo_lut *lut, double ln_i)
{
    return (int16_t)lround(fmin(32767, 256 * droop_codes(px, b, lut, ln_i)));
}

/* Every bin's droop from a grid of currents, inverted by interpolation: calibrate refreshes the
 * array at every margin it tries, and the build's 48 bisection steps per bin took 5 s a time on
 * sim-qvga's Reinhard ramp (the droop varies slowly with the current: the grid's 0.007 ln moves
 * it by under 1/256). */
#define DROOP_GRID 2048
static int fill_droop_from_grid(const wdr_ideal_pixel *px, const wdr_board *b, const expo_lut *lut,
                                wdr_lut_exposure *ex)
{
    double *ln_i = malloc(sizeof *ln_i * 2 * DROOP_GRID);
    if (!ln_i)
        return WDR_E_NOMEM;
    double *code = ln_i + DROOP_GRID;
    double lo = log(b->i_min_a), hi = log(b->i_max_a);
    for (int k = 0; k < DROOP_GRID; k++) {
        ln_i[k] = lo + (hi - lo) * k / (DROOP_GRID - 1);
        code[k] = ideal_code(px, b, lut, exp(ln_i[k])); /* falls as light rises */
    }
    for (uint32_t k = 0; k < ex->bins; k++) {
        double y = (double)(k << ex->code_shift), x = y >= code[0] ? lo : hi;
        if (y < code[0] && y > code[DROOP_GRID - 1]) {
            int a = 0, z = DROOP_GRID - 1; /* code[a] > y >= code[z] */
            while (z - a > 1) {
                int mid = (a + z) / 2;
                *(code[mid] > y ? &a : &z) = mid;
            }
            double span = code[a] - code[z];
            x = ln_i[a] + (span > 0 ? (code[a] - y) / span : 0) * (ln_i[z] - ln_i[a]);
        }
        ex->droop_q8[k] = droop_q8_at(px, b, lut, x);
    }
    free(ln_i);
    return WDR_OK;
}

/* The nominal pixel's codes on a grid of LN_GRID currents (0.0025 ln apart on sim-vga), each run
 * of one code (a DAC step that holds over a range of currents) put at its middle: at the bright
 * end one step holds 0.1-0.4 ln at one code, and bisecting the staircase found each bin's code at
 * a step's bright edge, so codes there read up to 0.25 ln bright (the HDR wedge's key +1 %). The
 * runs at the grid's ends keep their inner edge: the floor and the ceiling. Returns the points
 * kept (codes falling as light rises). */
#define LN_GRID 8192
static int code_curve(const wdr_ideal_pixel *px, const wdr_board *b, const expo_lut *lut, double *ln_i,
                      double *code)
{
    double lo = log(b->i_min_a), hi = log(b->i_max_a);
    for (int k = 0; k < LN_GRID; k++) {
        ln_i[k] = lo + (hi - lo) * k / (LN_GRID - 1);
        code[k] = ideal_code(px, b, lut, exp(ln_i[k]));
    }
    int kept = 0;
    for (int a = 0, z; a < LN_GRID; a = z + 1) {
        for (z = a; z + 1 < LN_GRID && code[z + 1] == code[a];)
            z++;
        double x = a == 0 ? ln_i[z] : z == LN_GRID - 1 ? ln_i[a] : 0.5 * (ln_i[a] + ln_i[z]);
        code[kept] = code[a]; /* kept <= a: nothing unread is overwritten */
        ln_i[kept++] = x;
    }
    return kept;
}

/* ln I of code y on the curve: linear between its points; past its ends the sensor's ends (the
 * floor's i_min, the ceiling's i_max), as the firmware reads them (fw_expo.c: expo_limits). */
static double ln_on_curve(const double *ln_i, const double *code, int n, double y, const wdr_board *b)
{
    if (y > code[0])
        return log(b->i_min_a);
    if (y < code[n - 1])
        return log(b->i_max_a);
    int a = 0, z = n - 1; /* code[a] >= y >= code[z] */
    while (z - a > 1) {
        int mid = (a + z) / 2;
        *(code[mid] >= y ? &a : &z) = mid;
    }
    double span = code[a] - code[z];
    return span > 0 ? ln_i[a] + (code[a] - y) / span * (ln_i[z] - ln_i[a]) : ln_i[a];
}

/* The least slope, in codes per ln, at which a code still says which current it is. Schlick's
 * response on sim-qvga holds its darkest 3 ln in about 8 codes (0.8 codes per ln) while a code's
 * noise there is 1.4 codes: a pixel read anywhere within 2 ln, and at face value those codes put
 * the key +8 % (step chart) and +14 to +18 % (HDR wedge) off. Flat past the last bin that resolves
 * 4 codes per ln, the firmware censors them below the floor and continues the density inside it
 * instead: -1.95 / +1.27 %. At the dark end only: cut at the bright end too, Exponential's
 * ceiling moved from 8.6 to 2.0 ln and its step chart went from -2.38 to +2.70 %. */
#define MIN_CODES_PER_LN 4.0

/* Bins k..k+1 resolve their currents: over bin k each code spans at most 1 / MIN_CODES_PER_LN ln. */
static bool bin_resolves(const wdr_lut_exposure *ex, uint32_t k)
{
    double drop = (ex->ln_q8[k] - ex->ln_q8[k + 1]) / 256.0;
    return drop * MIN_CODES_PER_LN <= (double)(1u << ex->code_shift);
}

/* The table made flat past the last bin that resolves its currents at the dark end: the floor then
 * lies where the response stops resolving, not at the sensor's i_min. */
static void flatten_unresolved_dark_end(wdr_lut_exposure *ex)
{
    if (ex->bins < 2u || ex->bins > WDR_LUT_EXPO_MAX_BINS)
        return; /* no sloped part to cut (the builder makes 64..1024 bins) */
    uint32_t ceiling = 0, dark = ex->bins - 1u;
    while (ceiling + 1u < ex->bins && ex->ln_q8[ceiling + 1u] >= ex->ln_q8[0])
        ceiling++; /* the ceiling's flat run */
    while (dark > 0 && ex->ln_q8[dark - 1u] <= ex->ln_q8[ex->bins - 1u])
        dark--; /* the floor's flat run */
    /* from the bin that resolves best, darkward to the first that does not: on sim-vga Schlick's
     * 2 ln in one bin lay before a last bin of 0.8 ln, and a walk back from the floor stopped there */
    uint32_t best = ceiling + 1u;
    for (uint32_t k = ceiling + 1u; k < dark; k++)
        best = ex->ln_q8[k] - ex->ln_q8[k + 1u] < ex->ln_q8[best] - ex->ln_q8[best + 1u] ? k : best;
    for (uint32_t k = best; k < dark; k++)
        if (!bin_resolves(ex, k)) {
            dark = k;
            break;
        }
    for (uint32_t k = dark + 1u; k < ex->bins; k++)
        ex->ln_q8[k] = ex->ln_q8[dark];
}

/* The first bin at the table's lowest value: the floor's flat run, as the firmware finds it. */
static uint32_t floor_bin(const wdr_lut_exposure *ex)
{
    uint32_t first_min = 0, last_max = 0;
    wdr_lut_exposure_flat_ends(ex, &first_min, &last_max);
    return first_min;
}

/* The most a code of the nominal pixel past the floor may lie off the firmware's line (fw_expo.c:
 * dark_tail_from_codes) for the firmware to read the dark tail from the codes' mean. The tail's
 * span moves by about (its span)^2 times the offset over the floor's codes to no light (14 codes on
 * sim-qvga's Schlick ramp): a quarter code is 0.1 ln on a tail of 2.5 ln. Reinhard's pixels past its floor
 * bend off the line by a code or more (its floor is where they stop crossing in time). */
#define LINEAR_DARK_TOLERANCE_CODES 0.25
#define LINEAR_DARK_POINTS 32

/* Past the floor, the nominal code is on the line through the floor's bin and the first bin of
 * the floor's flat run, in current, down to no light: what WDR_LUT_EXPO_LINEAR_DARK promises. */
static bool dark_end_is_linear(const wdr_ideal_pixel *px, const wdr_board *b, const expo_lut *lut,
                               const wdr_lut_exposure *ex, double key_amp, double *worst_codes)
{
    uint32_t b1 = floor_bin(ex);
    double floor_code = WDR_LUT_EXPO_FLOOR_CODE(b1, ex->code_shift) - 0.5;
    uint32_t b0 = floor_code > 0 ? (uint32_t)floor_code >> ex->code_shift : 0;
    *worst_codes = INFINITY;
    if (b1 <= b0 || b1 >= ex->bins)
        return false;
    double l0 = ex->ln_q8[b0] / 256.0, l1 = ex->ln_q8[b1] / 256.0, drop = 1 - exp(l1 - l0);
    double c0 = (double)(b0 << ex->code_shift), codes = (double)((b1 - b0) << ex->code_shift);
    if (!(drop > 0))
        return false;
    *worst_codes = 0;
    for (int k = 0; k <= LINEAR_DARK_POINTS; k++) {
        double frac = (double)k / LINEAR_DARK_POINTS; /* of the current at bin b0 */
        double line = c0 + (1 - frac) * codes / drop;
        double code = ideal_code(px, b, lut, frac * key_amp * exp(l0));
        *worst_codes = fmax(*worst_codes, fabs(code - line));
    }
    return *worst_codes <= LINEAR_DARK_TOLERANCE_CODES;
}

static int exposure_table(const wdr_board *b, const wdr_ideal_pixel *px, const expo_lut *lut, double key_amp,
                          wdr_lut_exposure *out);

int wdr_ramp_lut_exposure_table(const wdr_board *b, const wdr_lut_view *view, double key_amp, wdr_lut_exposure *out)
{
    wdr_ideal_pixel px;
    wdr_ideal_pixel_init(b, &px);
    expo_lut lut = {.view = view};
    if (wdr_lut_steps_init(&px, view, &lut.steps))
        return WDR_E_NOMEM;
    int rc = exposure_table(b, &px, &lut, key_amp, out);
    wdr_lut_steps_free(&lut.steps);
    return rc;
}

static int exposure_table(const wdr_board *b, const wdr_ideal_pixel *px, const expo_lut *lut, double key_amp,
                          wdr_lut_exposure *out)
{
    /* 1024 bins (4 codes each at 12 bits): the ends of a compressive operator's response hold a
     * decade in a few codes, and the firmware reads the floor and the ceiling from the table */
    uint32_t bits = b->adc_bits < 6 ? 6 : b->adc_bits > 10 ? 10 : b->adc_bits;
    out->bins = (uint16_t)(1u << bits);
    out->code_shift = (uint8_t)(b->adc_bits > (int)bits ? b->adc_bits - (int)bits : 0);
    out->flags = WDR_LUT_EXPO_DROOP;
    if (b->dark_current_a > 0) { /* a longer tick adds the dark current (fw_expo.c) */
        /* the pixels' mean: the board's figure is the median of a lognormal spread */
        double mean_a = b->dark_current_a * exp(0.5 * b->dark_sigma_ln * b->dark_sigma_ln);
        double q = 256 * log(mean_a / key_amp);
        out->flags |= WDR_LUT_EXPO_DARK;
        out->dark_ln_q8 = (int16_t)lround(fmax(-WDR_LUT_EXPO_MAX_LN_Q8, fmin(WDR_LUT_EXPO_MAX_LN_Q8, q)));
    }
    double *ln_i = malloc(sizeof *ln_i * 2 * LN_GRID);
    if (!ln_i)
        return WDR_E_NOMEM;
    double *code = ln_i + LN_GRID;
    int n = code_curve(px, b, lut, ln_i, code);
    for (uint32_t k = 0; k < out->bins; k++) {
        double first = (double)(k << out->code_shift); /* the firmware interpolates between bins */
        double ln_rel = ln_on_curve(ln_i, code, n, first, b) - log(key_amp);
        double q = fmax(-WDR_LUT_EXPO_MAX_LN_Q8, fmin(WDR_LUT_EXPO_MAX_LN_Q8, ln_rel * 256));
        out->ln_q8[k] = (int16_t)lround(q);
        out->droop_q8[k] = droop_q8_at(px, b, lut, ln_rel + log(key_amp));
    }
    free(ln_i);
    flatten_unresolved_dark_end(out);
    double worst;
    if (dark_end_is_linear(px, b, lut, out, key_amp, &worst))
        out->flags |= WDR_LUT_EXPO_LINEAR_DARK;
    return WDR_OK;
}

int wdr_ramp_lut_refresh_droop(uint8_t *bytes, size_t len, const wdr_board *b)
{
    wdr_lut_view lut;
    int rc = wdr_lut_parse(bytes, len, &lut);
    size_t end = rc ? 0 : wdr_lut_size(lut.h.entry_count);
    if (rc || len <= end)
        return rc; /* no exposure block: nothing to refresh */
    wdr_lut_exposure *ex = malloc(sizeof *ex);
    if (!ex)
        return WDR_E_NOMEM;
    rc = wdr_lut_exposure_parse(bytes + end, len - end, ex);
    if (!rc && (ex->flags & WDR_LUT_EXPO_DROOP)) {
        wdr_ideal_pixel px;
        wdr_ideal_pixel_init(b, &px);
        expo_lut steps = {.view = &lut};
        rc = wdr_lut_steps_init(&px, &lut, &steps.steps) ? WDR_E_NOMEM : fill_droop_from_grid(&px, b, &steps, ex);
        wdr_lut_steps_free(&steps.steps);
        if (!rc)
            wdr_lut_exposure_encode(ex, bytes + end);
    }
    free(ex);
    return rc;
}

int wdr_ramp_lut_append_exposure(uint8_t **bytes, size_t *len, const wdr_board *b, double key_amp)
{
    wdr_lut_view lut;
    int rc = wdr_lut_parse(*bytes, *len, &lut);
    if (rc)
        return rc;
    size_t end = wdr_lut_size(lut.h.entry_count);
    wdr_lut_exposure *ex = malloc(sizeof *ex);
    if (!ex)
        return WDR_E_NOMEM;
    rc = wdr_ramp_lut_exposure_table(b, &lut, key_amp, ex);
    if (rc) {
        free(ex);
        return rc;
    }
    size_t size = WDR_LUT_EXPO_BLOCK_SIZE_FOR(ex->bins, ex->flags);
    uint8_t *grown = realloc(*bytes, end + size);
    if (!grown) {
        free(ex);
        return WDR_E_NOMEM;
    }
    *bytes = grown;
    wdr_lut_exposure_encode(ex, grown + end);
    free(ex);
    *len = end + size;
    return WDR_OK;
}
