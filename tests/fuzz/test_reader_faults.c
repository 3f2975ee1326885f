/* Faults issue 14's fuzzing found in the file readers, each reproduced on a small crafted file:
 * the Radiance RLE hang (CVE-2021-42715 in Debian's stb_image 2.27), sizes that exhaust memory
 * (zero width, 6,000,000 x 20, an EXR data window of 100000 x 100000, a PFM of 65536 x 65536) and
 * directories given as files (ftell said LONG_MAX, then malloc(2^63)). Before the fixes the
 * first hangs (CTest's timeout fails it) and the others abort under ASan or allocate gigabytes. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <cmocka.h>
#include "board.h"
#include "file_io.h"
#include "hdr_image.h"
#include "wdr_err.h"
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

static char dir[64];

static const char *write_file(const char *name, const void *bytes, size_t n)
{
    static char path[128];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    assert_int_equal(fwrite(bytes, 1, n, f), n);
    fclose(f);
    return path;
}

static void expect_refused(const char *path, int want_rc, const char *want_text)
{
    float *lum = NULL;
    int w = 0, h = 0;
    char err[512] = "";
    int rc = wdr_hdr_load(path, &lum, &w, &h, err, sizeof err);
    printf("%s -> %d: %s\n", path, rc, err);
    assert_int_equal(rc, want_rc);
    assert_null(lum);
    assert_non_null(strstr(err, path));
    assert_non_null(strstr(err, want_text));
}

#define RADIANCE_HEAD "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n"

/* A new-style RLE scanline whose first run count is 0: stb_image 2.27 never advances. */
static void radiance_zero_run_is_an_error_not_a_hang(void **state)
{
    (void)state;
    uint8_t f[375];
    memset(f, 0, sizeof f);
    const char *head = RADIANCE_HEAD "-Y 8 +X 16\n";
    size_t n = strlen(head);
    memcpy(f, head, n);
    const uint8_t marker[] = {2, 2, 0, 16, 0};
    memcpy(f + n, marker, sizeof marker);
    expect_refused(write_file("zero_run.hdr", f, sizeof f), WDR_E_INVAL, "run count 0");
}

static void radiance_sizes_checked_before_allocation(void **state)
{
    (void)state;
    const char zero[] = RADIANCE_HEAD "-Y 20 +X 0\n";
    expect_refused(write_file("zero_width.hdr", zero, sizeof zero - 1), WDR_E_INVAL, "resolution");
    const char tall[] = RADIANCE_HEAD "-Y 6000000 +X 20\n\x02\x02\x00\x14";
    expect_refused(write_file("tall.hdr", tall, sizeof tall - 1), WDR_E_INVAL, "pixels");
    const char lying[] = RADIANCE_HEAD "-Y 4000 +X 4000\n\x02\x02\x0f\xa0";
    expect_refused(write_file("lying.hdr", lying, sizeof lying - 1), WDR_E_INVAL, "bytes");
}

static void pfm_size_checked_before_allocation(void **state)
{
    (void)state;
    const char big[] = "Pf\n65536 65536\n-1.0\n\0\0\0\0";
    expect_refused(write_file("big.pfm", big, sizeof big - 1), WDR_E_INVAL, "pixels");
    const char lying[] = "Pf\n4000 4000\n-1.0\n\0\0\0\0";
    expect_refused(write_file("lying.pfm", lying, sizeof lying - 1), WDR_E_INVAL, "truncated");
}

/* A 1x1 scanline EXR, written by hand (uncompressed half Y), with a data window as given. */
static size_t exr_with_window(uint8_t *out, int32_t max_x, int32_t max_y)
{
    size_t n = 0;
#define PUT(p, len) (memcpy(out + n, (p), (len)), n += (len))
#define PUT32(v) do { int32_t v_ = (v); PUT(&v_, 4); } while (0)
    const uint8_t magic[] = {0x76, 0x2f, 0x31, 0x01, 2, 0, 0, 0};
    PUT(magic, sizeof magic);
    PUT("channels\0chlist\0", 16);
    PUT32(19);
    PUT("Y\0", 2);
    PUT32(1); /* HALF */
    PUT("\0\0\0\0", 4);
    PUT32(1);
    PUT32(1);
    PUT("\0", 1);
    PUT("compression\0compression\0", 24);
    PUT32(1);
    PUT("\0", 1); /* NO_COMPRESSION */
    PUT("dataWindow\0box2i\0", 17);
    PUT32(16);
    PUT32(0);
    PUT32(0);
    PUT32(max_x);
    PUT32(max_y);
    PUT("displayWindow\0box2i\0", 20);
    PUT32(16);
    PUT32(0);
    PUT32(0);
    PUT32(0);
    PUT32(0);
    PUT("lineOrder\0lineOrder\0", 20);
    PUT32(1);
    PUT("\0", 1); /* INCREASING_Y */
    PUT("pixelAspectRatio\0float\0", 23);
    PUT32(4);
    float one = 1.0f;
    PUT(&one, 4);
    PUT("screenWindowCenter\0v2f\0", 23);
    PUT32(8);
    float zero2[2] = {0, 0};
    PUT(zero2, 8);
    PUT("screenWindowWidth\0float\0", 24);
    PUT32(4);
    PUT(&one, 4);
    PUT("\0", 1);
    uint64_t offset = n + 8;
    PUT(&offset, 8);
    PUT32(0);
    PUT32(2);
    PUT("\0\x3c", 2); /* half 1.0 */
    return n;
#undef PUT32
#undef PUT
}

static void exr_data_window_checked_before_allocation(void **state)
{
    (void)state;
    static uint8_t f[1024];
    size_t n = exr_with_window(f, 0, 0);
    const char *path = write_file("one.exr", f, n);
    float *lum = NULL;
    int w, h;
    char err[512] = "";
    int rc = wdr_hdr_load(path, &lum, &w, &h, err, sizeof err);
    printf("%s -> %d: %s\n", path, rc, err);
    assert_int_equal(rc, WDR_OK); /* the hand-made file is sound */
    assert_int_equal(w * h, 1);
    assert_float_equal(lum[0], 1.0f, 1e-6);
    free(lum);
    n = exr_with_window(f, 99999, 99999); /* 10^10 pixels: 120 GB of planes */
    expect_refused(write_file("huge.exr", f, n), WDR_E_INVAL, "data window");
    n = exr_with_window(f, 7999, 7999); /* within the limit, but 8000 chunks in a 300-byte file */
    expect_refused(write_file("tall.exr", f, n), WDR_E_INVAL, "data window");
}

static void directories_refused_by_name(void **state)
{
    (void)state;
    uint8_t *buf = (uint8_t *)"untouched";
    size_t len = 7;
    errno = 0;
    assert_int_equal(wdr_read_file(dir, &buf, &len), WDR_E_IO);
    assert_int_equal(errno, EISDIR);
    assert_null(buf);
    assert_int_equal(len, 0);
    wdr_board b;
    char err[256] = "";
    wdr_board_defaults(&b);
    assert_int_equal(wdr_board_load(dir, &b, err, sizeof err), WDR_E_IO);
    assert_non_null(strstr(err, dir));
    char hdr[80];
    snprintf(hdr, sizeof hdr, "%s/", dir);
    float *lum = NULL;
    int w, h;
    assert_int_not_equal(wdr_hdr_load(hdr, &lum, &w, &h, err, sizeof err), WDR_OK);
    assert_null(lum);
}

static int make_dir(void **state)
{
    (void)state;
    snprintf(dir, sizeof dir, "/tmp/wdr_fuzzrd_XXXXXX");
    return mkdtemp(dir) ? 0 : -1;
}

static int remove_dir(void **state)
{
    (void)state;
    char cmd[128];
    snprintf(cmd, sizeof cmd, "rm -rf %s", dir);
    return system(cmd);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(radiance_zero_run_is_an_error_not_a_hang),
        cmocka_unit_test(radiance_sizes_checked_before_allocation),
        cmocka_unit_test(pfm_size_checked_before_allocation),
        cmocka_unit_test(exr_data_window_checked_before_allocation),
        cmocka_unit_test(directories_refused_by_name),
    };
    return cmocka_run_group_tests(tests, make_dir, remove_dir);
}
