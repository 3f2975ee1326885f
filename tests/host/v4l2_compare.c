/* Frames a V4L2 reader received (raw, back to back: GREY 1 byte, Y16 2 bytes little-endian per
 * pixel, rows of `bytesperline`) against the PNGs `wdrctl capture` wrote of the same frames
 * (--bits 8 --negate for GREY, --raw for Y16), pixel for pixel. Prints the pixels compared and
 * the differences; exit 0 only when there are none.
 *   v4l2_compare grey|y16 WIDTH HEIGHT BYTESPERLINE FRAMES.raw N CAPTURE.png
 * One capture PNG stands for all N frames: the test's scene is noiseless, every frame the same. */
#include <png.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* A grey PNG of w x h, 8- or 16-bit, its samples as stored (16-bit: big-endian in the file). */
static int read_png(const char *path, int w, int h, int bits, unsigned *px)
{
    FILE *f = fopen(path, "rb");
    png_structp p = f ? png_create_read_struct(PNG_LIBPNG_VER_STRING, NULL, NULL, NULL) : NULL;
    png_infop info = p ? png_create_info_struct(p) : NULL;
    uint8_t *row = malloc((size_t)w * 2);
    int ok = 0;
    if (info && row && !setjmp(png_jmpbuf(p))) {
        png_init_io(p, f);
        png_read_info(p, info);
        ok = (int)png_get_image_width(p, info) == w && (int)png_get_image_height(p, info) == h &&
             png_get_bit_depth(p, info) == bits && png_get_color_type(p, info) == PNG_COLOR_TYPE_GRAY;
        for (int y = 0; ok && y < h; y++) {
            png_read_row(p, row, NULL);
            for (int x = 0; x < w; x++)
                px[(size_t)y * w + x] = bits == 16 ? (unsigned)row[2 * x] << 8 | row[2 * x + 1] : row[x];
        }
    }
    if (!ok)
        fprintf(stderr, "%s: not a %dx%d %d-bit grey PNG\n", path, w, h, bits);
    png_destroy_read_struct(p ? &p : NULL, info ? &info : NULL, NULL);
    if (f)
        fclose(f);
    free(row);
    return ok;
}

int main(int argc, char **argv)
{
    if (argc != 8)
        return fprintf(stderr, "usage: v4l2_compare grey|y16 W H BYTESPERLINE FRAMES.raw N CAPTURE.png\n"), 64;
    int y16 = !strcmp(argv[1], "y16"), w = atoi(argv[2]), h = atoi(argv[3]), bpl = atoi(argv[4]), n = atoi(argv[6]);
    int bpp = y16 ? 2 : 1;
    if (w <= 0 || h <= 0 || n <= 0 || bpl < w * bpp)
        return fprintf(stderr, "v4l2_compare: bad size\n"), 64;
    unsigned *want = malloc(sizeof *want * (size_t)w * h);
    uint8_t *frame = malloc((size_t)bpl * h);
    FILE *f = fopen(argv[5], "rb");
    if (!want || !frame || !f || !read_png(argv[7], w, h, y16 ? 16 : 8, want)) {
        fprintf(stderr, "v4l2_compare: cannot read %s or %s\n", argv[5], argv[7]);
        free(want), free(frame);
        if (f)
            fclose(f);
        return 66;
    }
    long compared = 0, differ = 0;
    for (int k = 0; k < n; k++) {
        if (fread(frame, 1, (size_t)bpl * h, f) != (size_t)bpl * h) {
            fprintf(stderr, "%s: frame %d of %d is short\n", argv[5], k + 1, n);
            fclose(f), free(want), free(frame);
            return 65;
        }
        for (int y = 0; y < h; y++)
            for (int x = 0; x < w; x++) {
                const uint8_t *p = frame + (size_t)y * bpl + (size_t)x * bpp;
                unsigned got = y16 ? (unsigned)p[0] | (unsigned)p[1] << 8 : (unsigned)p[0];
                compared++;
                if (got != want[(size_t)y * w + x] && differ++ < 3)
                    fprintf(stderr, "frame %d pixel (%d,%d): %u, capture %u\n", k, x, y, got, want[(size_t)y * w + x]);
            }
    }
    int extra = fgetc(f) != EOF;
    printf("%s: %d frames, pixels compared %ld, differences %ld%s\n", argv[1], n, compared, differ,
           extra ? " (and more bytes than frames)" : "");
    fclose(f);
    free(want);
    free(frame);
    return differ || extra ? 1 : 0;
}
