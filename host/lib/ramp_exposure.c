/* The exposure table that comes with a LUT (LUT 1.1, firmware/SPEC.md): for each bin of corrected
 * codes, ln(I / I_key) of the current whose nominal-pixel code is the bin's first code. The firmware
 * averages it over a frame for the scene's log-average against the key. */
#include "ramp.h"
#include "wdr_err.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

/* The hold droop until the middle row is read. The calibration's corrected codes are the array
 * median's, whose pixels wait half the readout after the ramp (4.8 ms on sim-vga, three times the
 * integration: 1.6 codes, 0.2-0.5 ln each at the ends of Reinhard's response). */
static double read_droop_v(const wdr_board *b)
{
    return b->hold_leak_a / b->c_hold_f * 0.5 * (b->height > 0 ? b->height - 1 : 0) * b->row_time_s;
}

/* Unrounded ADC code of an ideal pixel with current i under lut, read at the middle row. */
static double ideal_code(const wdr_ideal_pixel *px, const wdr_board *b, const wdr_lut_view *lut, double i)
{
    double v = wdr_pixel_sf_out(&px->dev, wdr_ramp_lut_ideal_response(px, lut, i) - read_droop_v(b));
    return (b->adc_gain * v + b->adc_offset_v - b->adc_lo_v) / (b->adc_hi_v - b->adc_lo_v) * ((1u << b->adc_bits) - 1u);
}

/* ln I whose code is `code`: the code falls as light rises, so bisect on [ln i_min, ln i_max]
 * (codes outside the sensor's range get its ends: the floor and the ceiling). */
static double ln_current_for_code(const wdr_ideal_pixel *px, const wdr_board *b, const wdr_lut_view *lut, double code)
{
    double lo = log(b->i_min_a), hi = log(b->i_max_a);
    for (int k = 0; k < 48; k++) {
        double mid = 0.5 * (lo + hi);
        if (ideal_code(px, b, lut, exp(mid)) > code)
            lo = mid; /* still too dark */
        else
            hi = mid;
    }
    return 0.5 * (lo + hi);
}

/* Codes the hold droop takes from code `code` per unit of (tick / own tick - 1): a pixel that
 * crossed at t_c holds G for (T - t_c) m + the row's read delay at tick ratio m; the read delay and
 * the own tick's droop are in the calibration's nominal response, the rest is (m - 1) (T - t_c). */
static double droop_codes(const wdr_ideal_pixel *px, const wdr_board *b, const wdr_lut_view *lut, double ln_i)
{
    double i = exp(ln_i), g = wdr_ramp_lut_ideal_response(px, lut, i);
    double t_end = (double)lut->h.t_integration_ticks * lut->h.tick_ps * 1e-12;
    double t_c = fmin(wdr_ideal_cross_time(px, i, g), t_end);
    double dv = b->hold_leak_a * (t_end - (t_c > 0 ? t_c : 0)) / b->c_hold_f;
    double scale = b->adc_gain / (b->adc_hi_v - b->adc_lo_v) * ((1u << b->adc_bits) - 1u);
    g -= read_droop_v(b);
    return scale * (wdr_pixel_sf_out(&px->dev, g) - wdr_pixel_sf_out(&px->dev, g - dv));
}

/* A bin's droop per unit of (tick / own tick - 1), in 1/256 code, at the current ln_i of its
 * first code, from the LUT's own integration time. */
static int16_t droop_q8_at(const wdr_ideal_pixel *px, const wdr_board *b, const wdr_lut_view *lut, double ln_i)
{
    return (int16_t)lround(fmin(32767, 256 * droop_codes(px, b, lut, ln_i)));
}

/* Every bin's droop from a grid of currents, inverted by interpolation: calibrate refreshes the
 * array at every margin it tries, and the build's 48 bisection steps per bin took 5 s a time on
 * sim-qvga's Reinhard ramp (the droop varies slowly with the current: the grid's 0.007 ln moves
 * it by under 1/256). */
#define DROOP_GRID 2048
static int fill_droop_from_grid(const wdr_ideal_pixel *px, const wdr_board *b, const wdr_lut_view *lut,
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

void wdr_ramp_lut_exposure_table(const wdr_board *b, const wdr_lut_view *lut, double key_amp, wdr_lut_exposure *out)
{
    wdr_ideal_pixel px;
    wdr_ideal_pixel_init(b, &px);
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
    for (uint32_t k = 0; k < out->bins; k++) {
        double first = (double)(k << out->code_shift); /* the firmware interpolates between bins */
        double ln_rel = ln_current_for_code(&px, b, lut, first) - log(key_amp);
        double q = fmax(-WDR_LUT_EXPO_MAX_LN_Q8, fmin(WDR_LUT_EXPO_MAX_LN_Q8, ln_rel * 256));
        out->ln_q8[k] = (int16_t)lround(q);
        out->droop_q8[k] = droop_q8_at(&px, b, lut, ln_rel + log(key_amp));
    }
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
        rc = fill_droop_from_grid(&px, b, &lut, ex);
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
    wdr_ramp_lut_exposure_table(b, &lut, key_amp, ex);
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
