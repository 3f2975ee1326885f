/* Fitting images onto the sensor (sim/resample.c): small bright sources keep their energy when a
 * large image shrinks (no point sampling), and the aspect is kept by crop and letterbox, with
 * what was done reported. */
#include "resample.h"
#include "wdr_err.h"
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <cmocka.h>

#define LAMPS 200

/* 200 one-pixel lamps of 1e4 cd/m2 on a 0.01 cd/m2 wall, 3200x2400 onto 640x480 (5x). */
static void lamps_keep_their_energy(void **state)
{
    (void)state;
    const int iw = 3200, ih = 2400, w = 640, h = 480;
    float *img = malloc(sizeof *img * iw * ih), *out = malloc(sizeof *out * w * h);
    int lx[LAMPS], ly[LAMPS];
    assert_non_null(img);
    assert_non_null(out);
    for (long i = 0; i < (long)iw * ih; i++)
        img[i] = 0.01f;
    uint32_t r = 12345;
    for (int k = 0; k < LAMPS; k++) { /* spread over a 20x10 grid, jittered inside each cell */
        r = r * 1664525u + 1013904223u;
        lx[k] = (k % 20) * 160 + 20 + (int)(r >> 8) % 120;
        ly[k] = (k / 20) * 240 + 20 + (int)(r >> 16) % 200;
        img[(long)ly[k] * iw + lx[k]] = 1e4f;
    }
    char what[300];
    assert_int_equal(wdr_resample_fit(img, iw, ih, out, w, h, WDR_FIT_CROP, what, sizeof what), WDR_OK);
    printf("%s\n", what);
    double in_sum = 0, out_sum = 0;
    for (long i = 0; i < (long)iw * ih; i++)
        in_sum += img[i];
    for (long i = 0; i < (long)w * h; i++)
        out_sum += out[i];
    double scale = (double)iw * ih / ((double)w * h), energy_error = out_sum * scale / in_sum - 1;
    /* each lamp: the energy in the 3x3 output pixels around it, over the wall's share */
    int kept = 0;
    double worst = 1;
    for (int k = 0; k < LAMPS; k++) {
        int cx = lx[k] * w / iw, cy = ly[k] * h / ih;
        double e = 0;
        for (int y = cy - 1; y <= cy + 1; y++)
            for (int x = cx - 1; x <= cx + 1; x++)
                if (x >= 0 && x < w && y >= 0 && y < h)
                    e += out[(long)y * w + x] - 0.01;
        double frac = e * scale / (1e4 - 0.01);
        kept += frac > 0.9;
        worst = fmin(worst, frac);
    }
    printf("total energy error %.2e; lamps keeping > 90 %% of their energy: %d of %d (worst %.3f)\n",
           energy_error, kept, LAMPS, worst);
    assert_true(fabs(energy_error) < 1e-3);
    assert_int_equal(kept, LAMPS);
    free(img);
    free(out);
}

/* A 2:1 panorama (1024x512) onto a 4:3 sensor (640x480): crop keeps the centre 1024*... columns,
 * letterbox puts bars above and below; a circle stays a circle in both. */
static void panorama_keeps_its_aspect(void **state)
{
    (void)state;
    const int iw = 1024, ih = 512, w = 640, h = 480;
    float *img = malloc(sizeof *img * iw * ih), *out = malloc(sizeof *out * w * h);
    assert_non_null(img);
    assert_non_null(out);
    for (int y = 0; y < ih; y++) /* a bright disc of radius 100 px at the centre */
        for (int x = 0; x < iw; x++)
            img[(long)y * iw + x] = hypot(x + 0.5 - iw / 2.0, y + 0.5 - ih / 2.0) < 100 ? 100.0f : 1.0f;
    char what[300];
    const wdr_fit fits[] = {WDR_FIT_CROP, WDR_FIT_LETTERBOX, WDR_FIT_STRETCH};
    for (int f = 0; f < 3; f++) {
        assert_int_equal(wdr_resample_fit(img, iw, ih, out, w, h, fits[f], what, sizeof what), WDR_OK);
        int xs = 0, ys = 0; /* the disc's width and height in output pixels (half-maximum) */
        for (int x = 0; x < w; x++)
            xs += out[(long)(h / 2) * w + x] > 50;
        for (int y = 0; y < h; y++)
            ys += out[(long)y * w + w / 2] > 50;
        printf("%-9s disc %d x %d px (aspect %.3f): %s\n", wdr_fit_name(fits[f]), xs, ys, (double)xs / ys, what);
        if (fits[f] == WDR_FIT_STRETCH)
            assert_true((double)xs / ys < 0.8); /* squeezed: 2:1 into 4:3 makes it 0.667 */
        else
            assert_true(fabs((double)xs / ys - 1) < 0.03);
        assert_non_null(strstr(what, wdr_fit_name(fits[f])));
    }
    assert_int_equal(wdr_resample_fit(img, iw, ih, out, w, h, WDR_FIT_LETTERBOX, what, sizeof what), WDR_OK);
    assert_true(out[0] == 0.0f && out[(long)(h / 2) * w] > 0.5f); /* bars above, picture at the sides */
    assert_non_null(strstr(what, "onto 640x320 at (0, 80)"));
    assert_int_equal(wdr_resample_fit(img, iw, ih, out, w, h, WDR_FIT_CROP, what, sizeof what), WDR_OK);
    assert_non_null(strstr(what, "source 683x512 at (170, 0)"));
    assert_int_equal(wdr_resample_fit(img, iw, ih, out, w, h, WDR_FIT_EXACT, what, sizeof what), WDR_E_GEOMETRY);
    free(img);
    free(out);
}

static void fit_names(void **state)
{
    (void)state;
    assert_int_equal(wdr_fit_from_name("resample"), WDR_FIT_CROP);
    assert_int_equal(wdr_fit_from_name("letterbox"), WDR_FIT_LETTERBOX);
    assert_int_equal(wdr_fit_from_name("squash"), -1);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(lamps_keep_their_energy),
        cmocka_unit_test(panorama_keeps_its_aspect),
        cmocka_unit_test(fit_names),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
