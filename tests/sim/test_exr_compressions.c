/* Every common EXR compression (ZIP, PIZ, PXR24, B44, DWAA, DWAB and the rest), half and float,
 * RGB and Y, written with OpenEXR's C++ library (wdr_exr_write) and read back through
 * wdr_hdr_load: the pixels must come back within each codec's own loss. Then the errors: a cut
 * DWAB file names the file, the part and the compression, and headers that claim more pixels
 * than the bounds or the file allow are refused before anything is allocated. */
#include "exr_read.h"
#include "hdr_image.h"
#include "wdr_err.h"
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include <cmocka.h>

#define W 67
#define H 41 /* odd: partial chunks for every codec (DWAB has 256 lines per chunk) */

static char dir[64];
static float planes[3][W * H], grey[W * H];

/* A smooth image over four decades (lossy codecs are built for smooth images), R, G, B differing. */
static void make_image(void)
{
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            double l = pow(10.0, -1.0 + 4.0 * x / (W - 1)) * (1.0 + 0.3 * y / (H - 1));
            planes[0][y * W + x] = (float)(l * 1.2);
            planes[1][y * W + x] = (float)l;
            planes[2][y * W + x] = (float)(l * 0.7);
            grey[y * W + x] = (float)(0.2126 * l * 1.2 + 0.7152 * l + 0.0722 * l * 0.7);
        }
}

typedef struct codec {
    const char *name;
    double tol_half, tol_float; /* worst relative luminance error allowed */
} codec;

/* Lossless codecs hold half to its rounding (2^-11) and float exactly; PXR24 keeps 15 bits of a
 * float's mantissa; B44 is lossy on half only (float channels are stored as they are); DWA is
 * lossy on R, G, B and Y at its default level 45. */
static const codec codecs[] = {
    {"none", 1e-3, 1e-6}, {"rle", 1e-3, 1e-6},   {"zips", 1e-3, 1e-6}, {"zip", 1e-3, 1e-6},
    {"piz", 1e-3, 1e-6},  {"pxr24", 1e-3, 1e-4}, {"b44", 2e-2, 1e-6},  {"b44a", 2e-2, 1e-6},
    {"dwaa", 3e-2, 3e-2}, {"dwab", 3e-2, 3e-2},
};

static double worst_error(const float *lum)
{
    double worst = 0;
    for (int i = 0; i < W * H; i++)
        worst = fmax(worst, fabs(lum[i] / grey[i] - 1));
    return worst;
}

static void one_case(const codec *c, int half, int rgb)
{
    char path[160], err[512];
    snprintf(path, sizeof path, "%s/%s_%s_%s.exr", dir, c->name, half ? "half" : "float", rgb ? "rgb" : "y");
    const float *const p[3] = {planes[0], planes[1], planes[2]};
    assert_int_equal(wdr_exr_write(path, grey, rgb ? p : NULL, W, H, c->name, half, err, sizeof err), WDR_OK);
    float *lum;
    int w, h;
    if (wdr_hdr_load(path, &lum, &w, &h, err, sizeof err))
        fail_msg("%s", err);
    assert_int_equal(w, W);
    assert_int_equal(h, H);
    double worst = worst_error(lum), tol = half ? c->tol_half : c->tol_float;
    printf("%-6s %-5s %-3s worst relative error %.2e (allowed %.0e)\n", c->name, half ? "half" : "float",
           rgb ? "RGB" : "Y", worst, tol);
    assert_true(worst <= tol);
    free(lum);
    unlink(path);
}

static void every_compression(void **state)
{
    (void)state;
    for (size_t k = 0; k < sizeof codecs / sizeof codecs[0]; k++)
        for (int half = 0; half < 2; half++)
            for (int rgb = 0; rgb < 2; rgb++)
                one_case(&codecs[k], half, rgb);
}

static void expect_error(const char *path, int want, const char *const *texts)
{
    float *lum = (float *)1;
    int w, h;
    char err[600] = "";
    int rc = wdr_hdr_load(path, &lum, &w, &h, err, sizeof err);
    printf("-> %d: %s\n", rc, err);
    assert_int_equal(rc, want);
    assert_null(lum);
    assert_non_null(strstr(err, path));
    for (int k = 0; texts[k]; k++)
        assert_non_null(strstr(err, texts[k]));
}

static long read_all(const char *path, unsigned char *buf, long cap)
{
    FILE *f = fopen(path, "rb");
    assert_non_null(f);
    long n = (long)fread(buf, 1, (size_t)cap, f);
    fclose(f);
    return n;
}

static void write_all(const char *path, const unsigned char *buf, long n)
{
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    assert_int_equal(fwrite(buf, 1, (size_t)n, f), (size_t)n);
    fclose(f);
}

/* Offset of the dataWindow attribute's box2i value in an EXR header. */
static long data_window_at(const unsigned char *buf, long n)
{
    static const char key[] = "dataWindow\0box2i";
    for (long i = 0; i + (long)sizeof key < n; i++)
        if (!memcmp(buf + i, key, sizeof key))
            return i + (long)sizeof key + 4; /* after the name, type and the u32 size */
    fail_msg("no dataWindow in the header");
    return -1;
}

static void put_i32(unsigned char *p, int32_t v)
{
    for (int k = 0; k < 4; k++)
        p[k] = (unsigned char)((uint32_t)v >> (8 * k));
}

static void errors_name_file_part_and_compression(void **state)
{
    (void)state;
    char full[160], path[160], err[512];
    static unsigned char buf[1 << 20];
    snprintf(full, sizeof full, "%s/full.exr", dir);
    if (wdr_exr_write(full, grey, NULL, W, H, "dwab", 1, err, sizeof err))
        fail_msg("%s", err);
    long n = read_all(full, buf, sizeof buf);

    snprintf(path, sizeof path, "%s/cut.exr", dir);
    write_all(path, buf, n * 2 / 3);
    expect_error(path, WDR_E_INVAL, (const char *const[]){"part 0", "compression dwab", NULL});

    long at = data_window_at(buf, n); /* xmin ymin xmax ymax */
    put_i32(buf + at + 8, 40000);     /* wider than WDR_EXR_MAX_SIDE */
    snprintf(path, sizeof path, "%s/wide.exr", dir);
    write_all(path, buf, n);
    expect_error(path, WDR_E_INVAL, (const char *const[]){"part 0", "compression dwab", "outside the limits", NULL});

    put_i32(buf + at + 8, W - 1);
    put_i32(buf + at + 12, 30000); /* 118 DWAB chunks of 256 lines: the file has no room for their offsets */
    snprintf(path, sizeof path, "%s/tall.exr", dir);
    write_all(path, buf, 600);
    expect_error(path, WDR_E_INVAL, (const char *const[]){"part 0", "compression dwab", NULL});
    unlink(full);
}

static void unknown_compression_named(void **state)
{
    (void)state;
    char path[160], err[512];
    snprintf(path, sizeof path, "%s/x.exr", dir);
    assert_int_equal(wdr_exr_write(path, grey, NULL, W, H, "jpeg", 0, err, sizeof err), WDR_E_INVAL);
    assert_non_null(strstr(err, "'jpeg'"));
}

static int make_dir(void **state)
{
    (void)state;
    make_image();
    snprintf(dir, sizeof dir, "/tmp/wdr_exr_XXXXXX");
    return mkdtemp(dir) ? 0 : -1;
}

static int remove_dir(void **state)
{
    (void)state;
    const char *files[] = {"cut.exr", "wide.exr", "tall.exr"};
    char path[160];
    for (size_t k = 0; k < sizeof files / sizeof files[0]; k++) {
        snprintf(path, sizeof path, "%s/%s", dir, files[k]);
        unlink(path);
    }
    return rmdir(dir);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(every_compression),
        cmocka_unit_test(errors_name_file_part_and_compression),
        cmocka_unit_test(unknown_compression_named),
    };
    return cmocka_run_group_tests(tests, make_dir, remove_dir);
}
