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
    return (b->adc_gain * v + b->adc_offset_v - b->adc_lo_v) / (b->adc_hi_v - b->adc_lo_v) *
           ((1u << b->adc_bits) - 1u);
}

/* ln I whose code is `code`: the code falls as light rises, so bisect on [ln i_min, ln i_max]
 * (codes outside the sensor's range get its ends: the floor and the ceiling). */
static double ln_current_for_code(const wdr_ideal_pixel *px, const wdr_board *b, const wdr_lut_view *lut,
                                  double code)
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

void wdr_ramp_lut_exposure_table(const wdr_board *b, const wdr_lut_view *lut, double key_amp, wdr_lut_exposure *out)
{
    wdr_ideal_pixel px;
    wdr_ideal_pixel_init(b, &px);
    out->code_shift = (uint8_t)(b->adc_bits > 6 ? b->adc_bits - 6 : 0);
    for (uint32_t k = 0; k < WDR_LUT_EXPO_BINS; k++) {
        double first = (double)(k << out->code_shift); /* the firmware interpolates between bins */
        double ln_rel = ln_current_for_code(&px, b, lut, first) - log(key_amp);
        double q = fmax(-WDR_LUT_EXPO_MAX_LN_Q8, fmin(WDR_LUT_EXPO_MAX_LN_Q8, ln_rel * 256));
        out->ln_q8[k] = (int16_t)lround(q);
    }
}

int wdr_ramp_lut_append_exposure(uint8_t **bytes, size_t *len, const wdr_board *b, double key_amp)
{
    wdr_lut_view lut;
    int rc = wdr_lut_parse(*bytes, *len, &lut);
    if (rc)
        return rc;
    size_t end = wdr_lut_size(lut.h.entry_count);
    uint8_t *grown = realloc(*bytes, end + WDR_LUT_EXPO_SIZE);
    if (!grown)
        return WDR_E_NOMEM;
    *bytes = grown;
    wdr_lut_exposure ex;
    (void)wdr_lut_parse(grown, end, &lut); /* the buffer moved */
    wdr_ramp_lut_exposure_table(b, &lut, key_amp, &ex);
    wdr_lut_exposure_encode(&ex, grown + end);
    *len = end + WDR_LUT_EXPO_SIZE;
    return WDR_OK;
}
