#include "tonemap.h"
#include <math.h>
#include <string.h>

double wdr_code_to_display(const wdr_ideal_pixel *px, const wdr_board *b, double code)
{
    double full = (double)((1u << b->adc_bits) - 1u);
    double v_adc = code / full * (b->adc_hi_v - b->adc_lo_v) + b->adc_lo_v;
    double v_out = (v_adc - b->adc_offset_v) / b->adc_gain;
    const wdr_pixel_dev *d = &px->dev;
    double g = v_out + wdr_vt(d->vt0_m3, d->gamma, d->phi2f, v_out) + sqrt(2.0 * d->sf_bias / d->beta3);
    double t = (px->v_dark - g) / px->swing;
    return isfinite(t) ? (t < 0 ? 0 : (t > 1 ? 1 : t)) : 0;
}

uint8_t wdr_display_to_u8(double t)
{
    t = t > 0 ? (t < 1 ? t : 1) : 0;
    return (uint8_t)lround(255.0 * pow(t, 1.0 / 2.2));
}

void wdr_side_by_side(const uint8_t *left, const uint8_t *right, int w, int h, uint8_t *rgb)
{
    int stride = 2 * w + 4;
    memset(rgb, 255, (size_t)3 * stride * h);
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++)
            for (int c = 0; c < 3; c++) {
                rgb[3 * ((size_t)y * stride + x) + c] = left[(size_t)y * w + x];
                rgb[3 * ((size_t)y * stride + w + 4 + x) + c] = right[(size_t)y * w + x];
            }
}
