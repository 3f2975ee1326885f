/* Shared set-up for the simulator tests: small boards, a chip with a LUT, frame statistics. */
#ifndef SIM_TEST_H
#define SIM_TEST_H
#include "ramp.h"
#include "wdr_err.h"
#include "wdr_sim.h"
#include <math.h>
#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <cmocka.h>

/* cmocka 1.1.5 (Debian 12) has no assert_double_equal; this one also names both values. */
#define assert_near(a, b, eps)                                                                             \
    do {                                                                                                   \
        double a_ = (a), b_ = (b);                                                                         \
        if (!(fabs(a_ - b_) <= (eps)))                                                                     \
            fail_msg("%s = %.9g, expected %s = %.9g within %g", #a, a_, #b, b_, (double)(eps));            \
    } while (0)

/* The default 0.35 um board, cut to w x h pixels. */
static inline void test_board(wdr_board *b, int w, int h)
{
    wdr_board_defaults(b);
    b->width = (uint16_t)w;
    b->height = (uint16_t)h;
}

/* A chip with a LUT for operator op and, if ramp is not NULL, that LUT's continuous ramp set. */
typedef struct test_chip {
    wdr_sim *s;
    uint8_t *lut_bytes;
    wdr_lut_view lut;
    wdr_ramp ramp;
} test_chip;

static inline void test_chip_open(test_chip *tc, const wdr_board *b, const char *op, uint64_t chip_seed)
{
    char err[512];
    size_t len;
    memset(tc, 0, sizeof *tc);
    if (wdr_ramp_board_lut(b, op, &tc->lut_bytes, &len, &tc->ramp, err, sizeof err))
        fail_msg("LUT for %s: %s", op, err);
    assert_int_equal(wdr_lut_parse(tc->lut_bytes, len, &tc->lut), WDR_OK);
    tc->s = wdr_sim_create(b, chip_seed);
    assert_non_null(tc->s);
    assert_int_equal(wdr_sim_set_lut(tc->s, &tc->lut), WDR_OK);
    assert_int_equal(wdr_sim_set_ramp(tc->s, tc->ramp.t, tc->ramp.v, tc->ramp.n), WDR_OK);
}

static inline void test_chip_close(test_chip *tc)
{
    wdr_sim_destroy(tc->s);
    free(tc->lut_bytes);
    wdr_ramp_free(&tc->ramp);
}

/* Every effect off, then the listed ones on (terminated by -1). */
static inline void only_effects(wdr_sim *s, ...)
{
    va_list ap;
    for (int k = 0; k < WDR_FX_COUNT; k++)
        wdr_sim_set_effect(s, k, WDR_FX_OFF);
    va_start(ap, s);
    for (int fx = va_arg(ap, int); fx >= 0; fx = va_arg(ap, int))
        wdr_sim_set_effect(s, fx, WDR_FX_ON);
    va_end(ap);
}

/* ADC code (unrounded) of a source-follower voltage on board b. */
static inline double test_adc_code(const wdr_board *b, double v)
{
    return (b->adc_gain * v + b->adc_offset_v - b->adc_lo_v) / (b->adc_hi_v - b->adc_lo_v) *
           ((1u << b->adc_bits) - 1u);
}

/* Mean and variance of n floats (two passes: no cancellation). */
static inline void frame_stats(const float *f, long n, double *mean, double *var)
{
    double m = 0, v = 0;
    for (long i = 0; i < n; i++)
        m += f[i];
    m /= n;
    for (long i = 0; i < n; i++)
        v += (f[i] - m) * (f[i] - m);
    *mean = m;
    *var = v / (n - 1);
}

/* Uniform frame at current amps, unquantised codes; returns a malloc'd frame. */
static inline float *uniform_frame(wdr_sim *s, double amps, uint64_t frame_seed)
{
    const wdr_board *b = wdr_sim_board(s);
    float *f = malloc((size_t)b->width * b->height * sizeof *f);
    assert_non_null(f);
    assert_int_equal(wdr_sim_set_uniform(s, amps), WDR_OK);
    assert_int_equal(wdr_sim_render_float(s, frame_seed, f), WDR_OK);
    return f;
}

#endif
