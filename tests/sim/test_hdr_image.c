/* HDR loading: OpenEXR (float and half, RGB and Y, scanline and tiled, written here with
 * OpenEXR's own C API), Radiance .hdr (stb_image_write) and PFM, all to luminance
 * Y = 0.2126 R + 0.7152 G + 0.0722 B; and clear errors for missing or foreign files. */
#include "hdr_image.h"
#include "image_io.h"
#include "wdr_err.h"
#include <math.h>
#include <openexr.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include <cmocka.h>
#include <stb_image_write.h>

#define W 37
#define H 23 /* odd sizes: partial chunks and tiles */

static char dir[64];

static float red(int x, int y) { return 0.5f + x + 0.0f * y; }
static float green(int x, int y) { return 0.25f * (1 + y) + 0.0f * x; }
static float blue(int x, int y) { return (float)(x + y) * 2; }
static double lum_at(int x, int y) { return 0.2126 * red(x, y) + 0.7152 * green(x, y) + 0.0722 * blue(x, y); }

/* float -> IEEE half for the test values (normal range, round to nearest) */
static uint16_t to_half(float f)
{
    uint32_t u;
    memcpy(&u, &f, sizeof u);
    uint32_t sign = (u >> 16) & 0x8000u, mant = u & 0x7fffffu;
    int exp = (int)((u >> 23) & 0xff) - 127 + 15;
    if (f == 0)
        return (uint16_t)sign;
    uint32_t h = sign | ((uint32_t)exp << 10) | (mant >> 13);
    return (uint16_t)(h + ((mant >> 12) & 1));
}

typedef struct exr_spec {
    int half, grey, tiled;
} exr_spec;

static float plane_value(int c, int grey, int x, int y)
{
    if (grey)
        return (float)lum_at(x, y);
    return c == 0 ? red(x, y) : c == 1 ? green(x, y) : blue(x, y);
}

static void fill_planes(const exr_spec *sp, float *pf, uint16_t *ph)
{
    for (int c = 0; c < 3; c++)
        for (int y = 0; y < H; y++)
            for (int x = 0; x < W; x++) {
                float v = plane_value(c, sp->grey, x, y);
                pf[(c * H + y) * W + x] = v;
                ph[(c * H + y) * W + x] = to_half(v);
            }
}

static void aim_encoder(exr_encode_pipeline_t *enc, const exr_spec *sp, float *pf, uint16_t *ph, int x0, int y0)
{
    for (int c = 0; c < enc->channel_count; c++) {
        const char *n = enc->channels[c].channel_name;
        int plane = n[0] == 'R' || n[0] == 'Y' ? 0 : n[0] == 'G' ? 1 : 2;
        size_t off = ((size_t)plane * H + y0) * W + x0;
        int bytes = sp->half ? 2 : 4;
        enc->channels[c].encode_from_ptr = sp->half ? (const uint8_t *)(ph + off) : (const uint8_t *)(pf + off);
        enc->channels[c].user_pixel_stride = bytes;
        enc->channels[c].user_line_stride = W * bytes;
        enc->channels[c].user_data_type = sp->half ? EXR_PIXEL_HALF : EXR_PIXEL_FLOAT;
        enc->channels[c].user_bytes_per_element = (int16_t)bytes;
    }
}

static void encode_chunk(exr_context_t ctx, exr_encode_pipeline_t *enc, int *started, exr_chunk_info_t *ci,
                         const exr_spec *sp, float *pf, uint16_t *ph, int x0, int y0)
{
    assert_int_equal(*started ? exr_encoding_update(ctx, 0, ci, enc) : exr_encoding_initialize(ctx, 0, ci, enc), 0);
    aim_encoder(enc, sp, pf, ph, x0, y0);
    if (!*started)
        assert_int_equal(exr_encoding_choose_default_routines(ctx, 0, enc), 0);
    *started = 1;
    assert_int_equal(exr_encoding_run(ctx, 0, enc), 0);
}

static void write_exr(const char *path, const exr_spec *sp)
{
    exr_context_t ctx;
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    int part;
    static float pf[3 * W * H];
    static uint16_t ph[3 * W * H];
    fill_planes(sp, pf, ph);
    assert_int_equal(exr_start_write(&ctx, path, EXR_WRITE_FILE_DIRECTLY, &init), 0);
    assert_int_equal(exr_add_part(ctx, "main", sp->tiled ? EXR_STORAGE_TILED : EXR_STORAGE_SCANLINE, &part), 0);
    assert_int_equal(exr_initialize_required_attr_simple(ctx, part, W, H, EXR_COMPRESSION_ZIP), 0);
    if (sp->tiled)
        assert_int_equal(exr_set_tile_descriptor(ctx, part, 16, 16, EXR_TILE_ONE_LEVEL, EXR_TILE_ROUND_DOWN), 0);
    const char *names[3] = {"R", "G", "B"};
    for (int c = 0; c < (sp->grey ? 1 : 3); c++)
        exr_add_channel(ctx, part, sp->grey ? "Y" : names[c], sp->half ? EXR_PIXEL_HALF : EXR_PIXEL_FLOAT,
                        EXR_PERCEPTUALLY_LOGARITHMIC, 1, 1);
    assert_int_equal(exr_write_header(ctx), 0);
    exr_encode_pipeline_t enc = EXR_ENCODE_PIPELINE_INITIALIZER;
    exr_chunk_info_t ci;
    int started = 0;
    if (sp->tiled) {
        for (int ty = 0; ty * 16 < H; ty++)
            for (int tx = 0; tx * 16 < W; tx++) {
                assert_int_equal(exr_write_tile_chunk_info(ctx, 0, tx, ty, 0, 0, &ci), 0);
                encode_chunk(ctx, &enc, &started, &ci, sp, pf, ph, tx * 16, ty * 16);
            }
    } else {
        int32_t lines;
        assert_int_equal(exr_get_scanlines_per_chunk(ctx, 0, &lines), 0);
        for (int y = 0; y < H; y += lines) {
            assert_int_equal(exr_write_scanline_chunk_info(ctx, 0, y, &ci), 0);
            encode_chunk(ctx, &enc, &started, &ci, sp, pf, ph, 0, y);
        }
    }
    exr_encoding_destroy(ctx, &enc);
    assert_int_equal(exr_finish(&ctx), 0);
}

static void check_luminance(const char *path, double rel_tol)
{
    float *lum;
    int w, h;
    char err[512];
    if (wdr_hdr_load(path, &lum, &w, &h, err, sizeof err))
        fail_msg("%s", err);
    assert_int_equal(w, W);
    assert_int_equal(h, H);
    double worst = 0;
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++)
            worst = fmax(worst, fabs(lum[y * W + x] / lum_at(x, y) - 1));
    printf("%s: worst relative luminance error %.2e\n", strrchr(path, '/') + 1, worst);
    assert_true(worst <= rel_tol);
    free(lum);
}

static void exr_case(const char *name, exr_spec sp, double tol)
{
    char path[128];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    write_exr(path, &sp);
    check_luminance(path, tol);
}

static void exr_float_rgb_scanline(void **s) { (void)s; exr_case("f_rgb.exr", (exr_spec){0, 0, 0}, 1e-6); }
static void exr_half_rgb_scanline(void **s) { (void)s; exr_case("h_rgb.exr", (exr_spec){1, 0, 0}, 1e-3); }
static void exr_float_rgb_tiled(void **s) { (void)s; exr_case("f_rgb_tiled.exr", (exr_spec){0, 0, 1}, 1e-6); }
static void exr_half_y_scanline(void **s) { (void)s; exr_case("h_y.exr", (exr_spec){1, 1, 0}, 1e-3); }

static void radiance_hdr(void **state)
{
    (void)state;
    char path[128];
    static float rgb[3 * W * H];
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            rgb[3 * (y * W + x)] = red(x, y);
            rgb[3 * (y * W + x) + 1] = green(x, y);
            rgb[3 * (y * W + x) + 2] = blue(x, y);
        }
    snprintf(path, sizeof path, "%s/rgb.hdr", dir);
    assert_true(stbi_write_hdr(path, W, H, 3, rgb));
    check_luminance(path, 2e-2); /* RGBE keeps 8 bits of mantissa per channel */
}

static void pfm_grey(void **state)
{
    (void)state;
    char path[128], err[256];
    static float lum[W * H];
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++)
            lum[y * W + x] = (float)lum_at(x, y);
    snprintf(path, sizeof path, "%s/grey.pfm", dir);
    assert_int_equal(wdr_pfm_write(path, lum, W, H, err, sizeof err), WDR_OK);
    check_luminance(path, 1e-6);
}

static void expect_error(const char *path, int want_rc, const char *want_text)
{
    float *lum = NULL;
    int w, h;
    char err[512] = "";
    int rc = wdr_hdr_load(path, &lum, &w, &h, err, sizeof err);
    printf("%s -> %d: %s\n", path, rc, err);
    assert_int_equal(rc, want_rc);
    assert_non_null(strstr(err, path));
    assert_non_null(strstr(err, want_text));
    free(lum);
}

static void bad_files(void **state)
{
    (void)state;
    char path[128];
    snprintf(path, sizeof path, "%s/missing.exr", dir);
    expect_error(path, WDR_E_IO, "cannot open");
    snprintf(path, sizeof path, "%s/text.exr", dir);
    FILE *f = fopen(path, "w");
    fputs("hello, not an image\n", f);
    fclose(f);
    expect_error(path, WDR_E_INVAL, "not an OpenEXR");
    /* an EXR cut in half: the header parses or not, the pixels cannot all be there */
    char full[128];
    snprintf(full, sizeof full, "%s/f_rgb.exr", dir);
    write_exr(full, &(exr_spec){0, 0, 0});
    snprintf(path, sizeof path, "%s/cut.exr", dir);
    FILE *in = fopen(full, "rb"), *out = fopen(path, "wb");
    char buf[65536];
    size_t n = fread(buf, 1, sizeof buf, in);
    fwrite(buf, 1, n / 2, out);
    fclose(in), fclose(out);
    expect_error(path, WDR_E_INVAL, "OpenEXR");
    /* fuzz_images, 2026-12-07: a header whose data window the C API reads within the limits and
     * OpenEXR's C++ library reads as 16,253,185 x 1 (a 50 GB strip): refused by
     * the second reading's bounds, with the window as that library reads it */
    expect_error(WDR_SOURCE_DIR "/tests/fuzz/corpus/images/exr_window_disagrees.exr", WDR_E_INVAL,
                 "as the OpenEXR library reads the header");
}

static int make_dir(void **state)
{
    (void)state;
    snprintf(dir, sizeof dir, "/tmp/wdr_hdr_XXXXXX");
    return mkdtemp(dir) ? 0 : -1;
}

static int remove_dir(void **state)
{
    (void)state;
    const char *files[] = {"f_rgb.exr", "h_rgb.exr", "f_rgb_tiled.exr", "h_y.exr", "rgb.hdr", "grey.pfm", "text.exr",
                           "cut.exr"};
    char path[128];
    for (size_t k = 0; k < sizeof files / sizeof files[0]; k++) {
        snprintf(path, sizeof path, "%s/%s", dir, files[k]);
        unlink(path);
    }
    return rmdir(dir);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(exr_float_rgb_scanline), cmocka_unit_test(exr_half_rgb_scanline),
        cmocka_unit_test(exr_float_rgb_tiled),    cmocka_unit_test(exr_half_y_scanline),
        cmocka_unit_test(radiance_hdr),           cmocka_unit_test(pfm_grey),
        cmocka_unit_test(bad_files),
    };
    return cmocka_run_group_tests(tests, make_dir, remove_dir);
}
