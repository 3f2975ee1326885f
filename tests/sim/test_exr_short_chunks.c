/* EXR reads never expose uninitialised memory, and multi-part headers are bounded before they
 * cost memory (issue 23). Files written by hand: an uncompressed UINT "Y" image whose chunks
 * hold fewer bytes than their lines (OpenEXR 3.1.5 filled the rest from a buffer it never
 * initialised and reported success), the same with whole chunks (read, for contrast), and a
 * multi-part file of 20,000 parts. CTest also runs this program under valgrind (exr_short_chunks_valgrind),
 * where any read of uninitialised memory fails it. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <cmocka.h>
#include "exr_read.h"
#include "wdr_err.h"
#include <openexr.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#define W 8
#define H 4

static char dir[64];
static uint8_t buf[1 << 20];
static size_t n;

#define PUT(p, len) (memcpy(buf + n, (p), (len)), n += (len))
static void put32(int32_t v) { PUT(&v, 4); }
static void put64(uint64_t v) { PUT(&v, 8); }
static void attr(const char *name, const char *type, int32_t size)
{
    PUT(name, strlen(name) + 1);
    PUT(type, strlen(type) + 1);
    put32(size);
}

/* The required attributes of a W x H scanline image, one UINT channel "Y", no compression. */
static void image_header(void)
{
    attr("channels", "chlist", 19);
    PUT("Y\0", 2);
    put32(0); /* UINT */
    PUT("\0\0\0\0", 4);
    put32(1);
    put32(1);
    PUT("\0", 1);
    attr("compression", "compression", 1);
    PUT("\0", 1); /* NO_COMPRESSION */
    int32_t box[4] = {0, 0, W - 1, H - 1};
    attr("dataWindow", "box2i", 16);
    PUT(box, 16);
    attr("displayWindow", "box2i", 16);
    PUT(box, 16);
    attr("lineOrder", "lineOrder", 1);
    PUT("\0", 1);
    float one = 1.0f, zero2[2] = {0, 0};
    attr("pixelAspectRatio", "float", 4);
    PUT(&one, 4);
    attr("screenWindowCenter", "v2f", 8);
    PUT(zero2, 8);
    attr("screenWindowWidth", "float", 4);
    PUT(&one, 4);
}

/* One chunk per line of `bytes` bytes (a whole line is W * 4). */
static const char *uint_file(const char *name, int32_t bytes)
{
    n = 0;
    const uint8_t magic[] = {0x76, 0x2f, 0x31, 0x01, 2, 0, 0, 0};
    PUT(magic, sizeof magic);
    image_header();
    PUT("\0", 1);
    uint64_t first = n + 8u * H;
    for (int y = 0; y < H; y++)
        put64(first + (uint64_t)y * (8u + (uint64_t)bytes));
    for (int y = 0; y < H; y++) {
        put32(y);
        put32(bytes);
        for (int32_t b = 0; b < bytes; b++)
            buf[n++] = (uint8_t)(y * 16 + b);
    }
    static char path[128];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    assert_int_equal(fwrite(buf, 1, n, f), n);
    fclose(f);
    return path;
}

static void whole_chunks_read(void **state)
{
    (void)state;
    float *lum;
    int w, h;
    char err[512];
    int rc = wdr_exr_read(uint_file("whole.exr", W * 4), &lum, &w, &h, err, sizeof err);
    if (rc != WDR_OK)
        fail_msg("%s", err);
    assert_int_equal(w, W);
    assert_int_equal(h, H);
    double sum = 0;
    for (int i = 0; i < W * H; i++)
        sum += lum[i]; /* valgrind: every value defined */
    assert_true(sum > 0);
    free(lum);
}

static void short_chunks_are_damaged(void **state)
{
    (void)state;
    const int32_t sizes[] = {4, W * 4 - 1, 1};
    for (size_t k = 0; k < sizeof sizes / sizeof sizes[0]; k++) {
        float *lum = NULL;
        int w, h;
        char err[512], name[32];
        snprintf(name, sizeof name, "short%d.exr", (int)sizes[k]);
        const char *path = uint_file(name, sizes[k]);
        int rc = wdr_exr_read(path, &lum, &w, &h, err, sizeof err);
        print_message("%d-byte chunks: %s\n", (int)sizes[k], err);
        assert_int_equal(rc, WDR_E_INVAL);
        assert_null(lum);
        assert_non_null(strstr(err, path));
        assert_non_null(strstr(err, "part 0"));
        assert_non_null(strstr(err, "damaged"));
    }
}

/* A 20x12 tiled (16x16 tiles) uncompressed float Y image; tile (1,0) holds `short_by` bytes too few. */
static const char *tiled_file(const char *name, uint64_t short_by)
{
    static char path[128];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    exr_context_t ctx;
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    int part;
    assert_int_equal(exr_start_write(&ctx, path, EXR_WRITE_FILE_DIRECTLY, &init), 0);
    assert_int_equal(exr_add_part(ctx, "main", EXR_STORAGE_TILED, &part), 0);
    assert_int_equal(exr_initialize_required_attr_simple(ctx, part, 20, 12, EXR_COMPRESSION_NONE), 0);
    assert_int_equal(exr_set_tile_descriptor(ctx, part, 16, 16, EXR_TILE_ONE_LEVEL, EXR_TILE_ROUND_DOWN), 0);
    exr_add_channel(ctx, part, "Y", EXR_PIXEL_FLOAT, EXR_PERCEPTUALLY_LOGARITHMIC, 1, 1);
    assert_int_equal(exr_write_header(ctx), 0);
    static float px[16 * 12];
    for (int i = 0; i < 16 * 12; i++)
        px[i] = 1.0f + (float)i;
    assert_int_equal(exr_write_tile_chunk(ctx, part, 0, 0, 0, 0, px, 16 * 12 * 4), 0);
    assert_int_equal(exr_write_tile_chunk(ctx, part, 1, 0, 0, 0, px, 4 * 12 * 4 - short_by), 0);
    assert_int_equal(exr_finish(&ctx), 0);
    return path;
}

static void tiled_chunks_checked(void **state)
{
    (void)state;
    float *lum = NULL;
    int w, h;
    char err[512];
    int rc = wdr_exr_read(tiled_file("tiled.exr", 0), &lum, &w, &h, err, sizeof err);
    if (rc != WDR_OK)
        fail_msg("whole tiles: %s", err);
    assert_true(w == 20 && h == 12 && lum[0] == 1.0f);
    free(lum);
    lum = NULL;
    const char *path = tiled_file("tiled_short.exr", 40);
    assert_int_equal(wdr_exr_read(path, &lum, &w, &h, err, sizeof err), WDR_E_INVAL);
    print_message("short tile: %s\n", err);
    assert_null(lum);
    assert_non_null(strstr(err, "damaged"));
    assert_non_null(strstr(err, "x 1, y 0"));
}

static void many_parts_refused_first(void **state)
{
    (void)state;
    n = 0;
    const uint8_t magic[] = {0x76, 0x2f, 0x31, 0x01, 2, 0x10, 0, 0}; /* multi-part */
    PUT(magic, sizeof magic);
    for (int p = 0; p < 20000; p++) {
        char part[16];
        snprintf(part, sizeof part, "p%d", p);
        attr("name", "string", (int32_t)strlen(part));
        PUT(part, strlen(part));
        attr("type", "string", 8);
        PUT("scanline", 8);
        PUT("\0", 1);
    }
    PUT("\0", 1);
    char path[128], err[512];
    snprintf(path, sizeof path, "%s/parts.exr", dir);
    FILE *f = fopen(path, "wb");
    fwrite(buf, 1, n, f);
    fclose(f);
    float *lum = NULL;
    int w, h;
    clock_t c0 = clock();
    assert_int_equal(wdr_exr_read(path, &lum, &w, &h, err, sizeof err), WDR_E_INVAL);
    print_message("20000 parts (%zu bytes): %.1f ms CPU: %s\n", n, (double)(clock() - c0) * 1e3 / CLOCKS_PER_SEC, err);
    assert_non_null(strstr(err, "more than 64 parts"));
}

static int make_dir(void **state)
{
    (void)state;
    snprintf(dir, sizeof dir, "/tmp/wdr-exr-XXXXXX");
    return mkdtemp(dir) ? 0 : -1;
}

static int remove_dir(void **state)
{
    (void)state;
    char cmd[96];
    snprintf(cmd, sizeof cmd, "rm -rf %s", dir);
    return system(cmd) == 0 ? 0 : -1;
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(whole_chunks_read),
        cmocka_unit_test(short_chunks_are_damaged),
        cmocka_unit_test(tiled_chunks_checked),
        cmocka_unit_test(many_parts_refused_first),
    };
    return cmocka_run_group_tests(tests, make_dir, remove_dir);
}
