/* The exposure table that comes with a LUT (LUT 1.1, firmware/SPEC.md): for each bin of corrected
 * codes, ln(I / I_key) of the current whose nominal-pixel code is the bin's first code. The firmware
 * averages it over a frame for the scene's log-average against the key. */
#include "ramp.h"
#include "wdr_err.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Unrounded ADC code of an ideal pixel with current i under lut. */
static double ideal_code(const wdr_ideal_pixel *px, const wdr_board *b, const wdr_lut_view *lut, double i)
{
    double v = wdr_pixel_sf_out(&px->dev, wdr_ramp_lut_ideal_response(px, lut, i));
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
    return scale * (wdr_pixel_sf_out(&px->dev, g) - wdr_pixel_sf_out(&px->dev, g - dv));
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
    for (uint32_t k = 0; k < out->bins; k++) {
        double first = (double)(k << out->code_shift); /* the firmware interpolates between bins */
        double ln_rel = ln_current_for_code(&px, b, lut, first) - log(key_amp);
        double q = fmax(-WDR_LUT_EXPO_MAX_LN_Q8, fmin(WDR_LUT_EXPO_MAX_LN_Q8, ln_rel * 256));
        out->ln_q8[k] = (int16_t)lround(q);
        out->droop_q8[k] = (int16_t)lround(fmin(32767, 256 * droop_codes(&px, b, lut, ln_rel + log(key_amp))));
    }
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
