/* vm_board_model: the VM test's side of the virtual board's sensor model (vboard/vboard_model.h).
 *
 *   vm_board_model cal OUT.cal GAIN
 *       writes a calibration table for the Linux board (vboard_pins.h geometry) whose every
 *       pixel maps a raw code y to GAIN * y + an offset of -32..31 that varies with row and column;
 *   vm_board_model check LUT.bin FRAME.pfm [GAIN]
 *       checks a captured frame pixel by pixel against what the model must have answered with
 *       that LUT played (and, given GAIN, that calibration applied). Prints the number
 *       of wrong pixels and the first few; exit 0 only when every pixel matches;
 *   vm_board_model crc FILE
 *       prints the CRC-32 of a table file as `wdrctl status` shows a stored table's. */
#include "crc32.h"
#include "file_io.h"
#include "image_io.h"
#include "vboard_model.h"
#include "vboard_pins.h"
#include "wdr_cal.h"
#include "wdr_err.h"
#include "wdr_lut.h"
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sysexits.h>

#define CODE_MAX ((1u << VB_ADC_BITS) - 1u)

/* The per-pixel offset of the test calibration: varies along rows and columns, so that a table
 * row applied to the wrong sensor row, or shifted by a column, shows. */
static int pixel_offset(unsigned row, unsigned col)
{
    return (int)((row * 7u + col * 3u) % 64u) - 32;
}

/* A POLY table of 2 coefficients (the smallest a table can be: 2.8 MB for VGA): pixel (r, c)
 * maps y to gain * y + pixel_offset(r, c). */
static int write_cal(const char *path, float gain)
{
    enum { W = VB_WIDTH, H = VB_HEIGHT, N = W * H };
    size_t size = wdr_cal_size(W, H, 2);
    float *coeffs = malloc(2u * N * sizeof *coeffs);
    uint8_t *flags = calloc(N, 1), *out = aligned_alloc(4, (size + 3u) & ~(size_t)3u);
    if (!coeffs || !flags || !out) {
        free(coeffs);
        free(flags);
        free(out);
        return EX_OSERR;
    }
    wdr_cal_header h;
    memset(&h, 0, sizeof h);
    h.sensor_id = VB_SENSOR_ID;
    h.width = W;
    h.height = H;
    h.form = WDR_FORM_POLY; /* c0 + c1 u, u = y */
    h.n_coeffs = 2;
    h.in_scale = 1.0f;
    h.out_scale = 1.0f;
    h.out_max = (uint16_t)CODE_MAX;
    h.raw_max = (uint16_t)CODE_MAX;
    for (unsigned r = 0; r < H; r++)
        for (unsigned c = 0; c < W; c++) {
            coeffs[r * W + c] = (float)pixel_offset(r, c);
            coeffs[N + r * W + c] = gain;
        }
    wdr_cal_encode(&h, coeffs, flags, out);
    FILE *f = fopen(path, "wb");
    int ok = f && fwrite(out, 1, size, f) == size;
    if (f && fclose(f) != 0)
        ok = 0;
    free(coeffs);
    free(flags);
    free(out);
    if (!ok) {
        fprintf(stderr, "vm_board_model: cannot write %s\n", path);
        return EX_CANTCREAT;
    }
    return EX_OK;
}

static int load_lut(const char *path, uint16_t **codes, uint32_t *n)
{
    uint8_t *buf;
    size_t len;
    wdr_lut_view lut;
    if (wdr_read_file(path, &buf, &len) != WDR_OK || wdr_lut_parse(buf, len, &lut) != WDR_OK) {
        fprintf(stderr, "vm_board_model: %s: not a readable LUT\n", path);
        return EX_DATAERR;
    }
    *n = lut.h.entry_count;
    *codes = malloc(*n * sizeof **codes);
    for (uint32_t i = 0; *codes && i < *n; i++) {
        uint32_t t;
        wdr_lut_entry(&lut, i, &t, &(*codes)[i]);
    }
    free(buf);
    return *codes && *n <= VB_MAX_STEPS ? EX_OK : EX_DATAERR;
}

/* What the firmware sends for raw code y of pixel (r, c) with the test table (rounded, clamped). */
static double corrected(double y, unsigned r, unsigned c, int have_cal, double gain)
{
    if (!have_cal)
        return y;
    double v = floor(gain * y + pixel_offset(r, c) + 0.5);
    return v < 0 ? 0 : v > CODE_MAX ? CODE_MAX : v;
}

static int check(const char *lut_path, const char *frame_path, int have_cal, double gain)
{
    uint16_t *steps;
    uint32_t n;
    int rc = load_lut(lut_path, &steps, &n);
    if (rc != EX_OK)
        return rc;
    float *px;
    int w, h;
    char err[256];
    if (wdr_pfm_read(frame_path, &px, &w, &h, err, sizeof err) != WDR_OK) {
        fprintf(stderr, "vm_board_model: %s\n", err);
        return EX_DATAERR;
    }
    if (w != VB_WIDTH || h != VB_HEIGHT) {
        fprintf(stderr, "vm_board_model: %s: %dx%d, the board is %ux%u\n", frame_path, w, h, VB_WIDTH,
                VB_HEIGHT);
        return EX_DATAERR;
    }
    long wrong = 0;
    for (int r = 0; r < h; r++)
        for (int c = 0; c < w; c++) {
            double want =
                corrected(steps[vb_pixel_step((unsigned)r, (unsigned)c, n)], (unsigned)r, (unsigned)c, have_cal, gain);
            double got = px[(size_t)r * (size_t)w + (size_t)c];
            if (got != want && wrong++ < 5)
                printf("pixel (%d, %d): %g, the model says %g\n", r, c, got, want);
        }
    printf("%s: %ld of %d pixels differ from the sensor model (%u ramp steps%s)\n", frame_path, wrong, w * h, n,
           have_cal ? ", calibration applied" : "");
    free(px);
    free(steps);
    return wrong ? EX_DATAERR : EX_OK;
}

static int print_crc(const char *path)
{
    uint8_t *buf;
    size_t len;
    if (wdr_read_file(path, &buf, &len) != WDR_OK) {
        fprintf(stderr, "vm_board_model: cannot read %s\n", path);
        return EX_NOINPUT;
    }
    printf("%08x\n", wdr_crc32(0, buf, len));
    free(buf);
    return EX_OK;
}

int main(int argc, char **argv)
{
    if (argc == 3 && !strcmp(argv[1], "crc"))
        return print_crc(argv[2]);
    if (argc == 4 && !strcmp(argv[1], "cal"))
        return write_cal(argv[2], strtof(argv[3], NULL));
    if ((argc == 4 || argc == 5) && !strcmp(argv[1], "check"))
        return check(argv[2], argv[3], argc == 5, argc == 5 ? atof(argv[4]) : 1);
    fprintf(stderr, "usage: vm_board_model cal OUT.cal GAIN | check LUT.bin FRAME.pfm [GAIN] | crc FILE\n");
    return EX_USAGE;
}
