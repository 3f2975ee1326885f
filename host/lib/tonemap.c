#include "tonemap.h"
#include "label_font.h"
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

double wdr_response_current(const wdr_response_curve *c, double code)
{
    int n = c->n;
    if (n < 2)
        return 0;
    if (!(code < c->code[0])) /* darker than the first point (also NaN): its current */
        return exp(c->ln_x[0]);
    if (!(code > c->code[n - 1]))
        return exp(c->ln_x[n - 1]);
    int lo = 0, hi = n - 1; /* code[lo] > code >= code[hi] */
    while (hi - lo > 1) {
        int mid = (lo + hi) / 2;
        if (code < c->code[mid])
            lo = mid;
        else
            hi = mid;
    }
    double f = (c->code[lo] - code) / (c->code[lo] - c->code[hi]);
    return exp(c->ln_x[lo] + f * (c->ln_x[hi] - c->ln_x[lo]));
}

double wdr_code_to_display_curve(const wdr_response_curve *c, const wdr_operator *op, double lum_per_amp, double code)
{
    double t = wdr_operator_eval(op, lum_per_amp * wdr_response_current(c, code));
    return isfinite(t) ? (t < 0 ? 0 : (t > 1 ? 1 : t)) : 0;
}

uint8_t wdr_display_to_u8(double t)
{
    t = t > 0 ? (t < 1 ? t : 1) : 0;
    return (uint8_t)lround(255.0 * pow(t, 1.0 / 2.2));
}

/* Label glyph size: readable at a glance, whatever the sensor's width. */
static int label_scale(int w) { return w >= 320 ? w / 160 : 1; }

static int band_height(int w) { return (WDR_LABEL_GLYPH_H + 4) * label_scale(w); }

int wdr_side_by_side_h(int w, int h) { return h + band_height(w); }

void wdr_side_by_side(const uint8_t *left, const uint8_t *right, int w, int h, const char *left_label,
                      const char *right_label, uint8_t *rgb)
{
    int stride = WDR_SIDE_BY_SIDE_W(w), band = band_height(w), scale = label_scale(w);
    int total_h = h + band;
    memset(rgb, 255, (size_t)3 * stride * total_h);
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++)
            for (int c = 0; c < 3; c++) {
                rgb[3 * ((size_t)(y + band) * stride + x) + c] = left[(size_t)y * w + x];
                rgb[3 * ((size_t)(y + band) * stride + w + 4 + x) + c] = right[(size_t)y * w + x];
            }
    /* each label centred over its half, in the band */
    wdr_label_draw(rgb, stride, total_h, (w - wdr_label_width(left_label, scale)) / 2, 2 * scale, scale, 0,
                   left_label);
    wdr_label_draw(rgb, stride, total_h, w + 4 + (w - wdr_label_width(right_label, scale)) / 2, 2 * scale, scale,
                   0, right_label);
}
