/* Tables for tests, built with the formats' own encoders. No HAL: any test may link it. */
#include "table_builders.h"
#include "wdr_cal.h"
#include "wdr_lut.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

size_t th_make_lut(uint8_t *out, uint32_t n, uint16_t code0, uint8_t dac_bits)
{
    static uint32_t t[WDR_LUT_MAX_ENTRIES];
    static uint16_t codes[WDR_LUT_MAX_ENTRIES];
    wdr_lut_header h;
    memset(&h, 0, sizeof h);
    h.operator_id = WDR_OP_REINHARD;
    h.dac_bits = dac_bits;
    h.timing = WDR_TIMING_STAMPED;
    h.entry_count = n;
    h.tick_ps = 1000;
    h.t_integration_ticks = n * 100u + 50u;
    h.dac_lo_v = 0.0f;
    h.dac_hi_v = 3.3f;
    for (uint32_t i = 0; i < n; i++) {
        t[i] = i * 100u;
        codes[i] = (uint16_t)((code0 + i) & ((1u << dac_bits) - 1u));
    }
    wdr_lut_encode(&h, t, codes, out);
    return wdr_lut_size(n);
}

size_t th_make_cal(uint8_t *out, float gain, float offset, uint32_t sensor_id, uint16_t w, uint16_t h)
{
    static float coeffs[3 * 4096 * 64];
    static uint8_t flags[4096 * 64];
    size_t n = (size_t)w * h;
    if (n > 4096 * 64)
        abort();
    wdr_cal_header hd;
    memset(&hd, 0, sizeof hd);
    hd.sensor_id = sensor_id;
    hd.width = w;
    hd.height = h;
    hd.form = WDR_FORM_MOEBIUS;
    hd.n_coeffs = 3;
    hd.model = WDR_MODEL_LSQ;
    hd.operator_id = WDR_OP_REINHARD;
    hd.in_scale = 1.0f;
    hd.out_scale = 1.0f;
    hd.out_max = 4095;
    hd.raw_max = 4095;
    for (size_t i = 0; i < n; i++) {
        coeffs[i] = gain;
        coeffs[n + i] = offset;
        coeffs[2 * n + i] = 0.0f;
    }
    memset(flags, 0, n);
    wdr_cal_encode(&hd, coeffs, flags, out);
    return wdr_cal_size(w, h, 3);
}


/* A kink at code 2048, on a point of the shared grid, so linear interpolation is exact. */
float th_basis_curve(float y) { return y < 2048.0f ? y : 2048.0f + 0.5f * (y - 2048.0f); }

float th_basis_expect(int row, int col, float y)
{
    return (10.0f + 0.5f * (float)row) + (0.5f + 0.001f * (float)col) * th_basis_curve(y);
}

#define TH_BASIS_POINTS 1025u

size_t th_make_cal_basis(uint8_t *out, uint32_t sensor_id, uint16_t w, uint16_t h, int poison)
{
    static float coeffs[2 * 4096 * 64], shared[2 * TH_BASIS_POINTS];
    static uint8_t flags[4096 * 64];
    size_t n = (size_t)w * h;
    if (n > 4096 * 64)
        abort();
    for (uint32_t j = 0; j < TH_BASIS_POINTS; j++) {
        shared[2 * j] = 1.0f;
        shared[2 * j + 1] = th_basis_curve(4.0f * (float)j);
    }
    if (poison)
        shared[2 * 300 + 1] = NAN;
    for (size_t i = 0; i < n; i++) {
        coeffs[i] = 10.0f + 0.5f * (float)(i / w);
        coeffs[n + i] = 0.5f + 0.001f * (float)(i % w);
    }
    memset(flags, 0, n);
    wdr_cal_header hd;
    memset(&hd, 0, sizeof hd);
    hd.sensor_id = sensor_id;
    hd.width = w;
    hd.height = h;
    hd.form = WDR_FORM_BASIS;
    hd.n_coeffs = 2;
    hd.shared_points = TH_BASIS_POINTS;
    hd.model = WDR_MODEL_SPLINE;
    hd.operator_id = WDR_OP_DRAGO;
    hd.in_scale = 0.25f;
    hd.out_scale = 1.0f;
    hd.out_max = 4095;
    hd.raw_max = 4095;
    wdr_cal_encode_basis(&hd, shared, coeffs, flags, out);
    return wdr_cal_size_basis(w, h, 2, TH_BASIS_POINTS);
}

size_t th_make_cal_wrapped(uint8_t *out, uint32_t sensor_id, uint16_t w, uint16_t h)
{
    static float coeffs[4 * 4096 * 64];
    static uint8_t flags[4096 * 64];
    const float shared[4] = {1.0f, 1.0f, 1.0f, 1.0f};
    size_t n = (size_t)w * h;
    if (n > 4096 * 64)
        abort();
    for (size_t i = 0; i < 4 * n; i++)
        coeffs[i] = 1.0f;
    memset(flags, 0, n);
    wdr_cal_header hd;
    memset(&hd, 0, sizeof hd);
    hd.sensor_id = sensor_id;
    hd.width = w;
    hd.height = h;
    hd.form = WDR_FORM_BASIS;
    hd.n_coeffs = 4;
    hd.shared_points = TH_WRAPPED_POINTS;
    hd.model = WDR_MODEL_SPLINE;
    hd.in_scale = 1.0f;
    hd.out_scale = 1.0f;
    hd.out_max = 4095;
    hd.raw_max = 4095;
    /* The encoder multiplies in u32 as the old check did: 4 shared floats, payload_len to match. */
    wdr_cal_encode_basis(&hd, shared, coeffs, flags, out);
    return WDR_CAL_HEADER_SIZE + hd.payload_len;
}
