/* READOUT's per-row path against memcpy of the same bytes, in one run: the correction kernel
 * alone, and the whole row path the firmware runs (row block of the table copied in as from
 * flash, correction into the ROW frame, frame header and CRC). Prints ns/pixel and ratios;
 * no assertion on time. --quick: a few frames, for CI. */
#include "bench_util.h"
#include "correct.h"
#include "wdr_cal.h"
#include "wdr_err.h"
#include "wdr_proto.h"
#include "wdr_readout.h"
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#define W 640
#define H 480

static uint16_t raw[H][W], out_frame[H][W];
static uint32_t frame_buf[(WDR_PROTO_MAX_FRAME + 3) / 4];
static uint32_t row_block[(W * 3 * 4 + W) / 4];
static uint16_t sink[W];
static volatile uint32_t keep;

typedef void (*frame_fn)(void *ctx);

/* Best of `reps` runs of one whole frame, in ns per pixel. */
static double time_frames(frame_fn fn, void *ctx, int reps)
{
    double best = 1e30;
    for (int r = 0; r < reps; r++) {
        double t0 = now_s();
        fn(ctx);
        double t = now_s() - t0;
        if (t < best)
            best = t;
    }
    return best * 1e9 / (W * H);
}

static void frame_memcpy(void *ctx)
{
    (void)ctx;
    for (int r = 0; r < H; r++) {
        memcpy(sink, raw[r], sizeof sink);
        keep += sink[r % W];
    }
}

static void frame_memcpy_whole(void *ctx)
{
    (void)ctx;
    memcpy(out_frame, raw, sizeof raw);
    keep += out_frame[H - 1][W - 1];
}

static void frame_kernel(void *ctx)
{
    wdr_cal_view rv = *(const wdr_cal_view *)ctx;
    if (rv.h.form != WDR_FORM_IDENTITY) {
        rv.h.height = 1;
        rv.payload = (const uint8_t *)row_block;
    }
    for (int r = 0; r < H; r++) {
        wdr_correct_row(&rv, rv.h.form == WDR_FORM_IDENTITY ? r : 0, raw[r], sink);
        keep += sink[r % W];
    }
}

/* As READOUT: the row's coefficients come in from the table store, then wdr_readout_row. */
static void frame_readout(void *ctx)
{
    const wdr_cal_view *cal = ctx;
    for (int r = 0; r < H; r++) {
        uint32_t len;
        const uint32_t *block = NULL;
        if (cal->payload) {
            memcpy(row_block, cal->payload + (size_t)r * cal->row_stride, cal->row_stride);
            block = row_block;
        }
        if (wdr_readout_row(cal, block, (uint16_t)r, 1, 7, raw[r], (uint8_t *)frame_buf, &len)) {
            fprintf(stderr, "bench_fw_readout: readout failed at row %d\n", r);
            exit(1);
        }
        keep += len;
    }
}

/* A Moebius table with a spread of coefficients, as a calibration would produce. */
static uint8_t *make_moebius(wdr_cal_view *v)
{
    size_t n = (size_t)W * H;
    float *c = malloc(3 * n * sizeof *c);
    uint8_t *flags = calloc(n, 1), *buf = malloc(wdr_cal_size(W, H, 3));
    if (!c || !flags || !buf)
        exit(1);
    for (size_t i = 0; i < n; i++) {
        c[i] = 0.9f + 0.2f * (float)(i % 97) / 97.0f;
        c[n + i] = (float)(i % 13);
        c[2 * n + i] = 1e-5f * (float)(i % 7);
    }
    wdr_cal_header h = {0};
    h.sensor_id = 1, h.width = W, h.height = H, h.form = WDR_FORM_MOEBIUS, h.n_coeffs = 3;
    h.in_scale = 1.0f, h.out_scale = 1.0f, h.out_max = 4095, h.raw_max = 4095;
    wdr_cal_encode(&h, c, flags, buf);
    free(c);
    free(flags);
    if (wdr_cal_parse(buf, wdr_cal_size(W, H, 3), v)) {
        fprintf(stderr, "bench_fw_readout: table did not parse\n");
        exit(1);
    }
    memcpy(row_block, v->payload, v->row_stride);
    return buf;
}

int main(int argc, char **argv)
{
    int reps = argc > 1 && !strcmp(argv[1], "--quick") ? 3 : 40;
    for (int r = 0; r < H; r++)
        for (int c = 0; c < W; c++)
            raw[r][c] = (uint16_t)((r * 83 + c * 29) & 0xfff);
    wdr_cal_view ident, moeb;
    if (wdr_cal_identity(&ident, 1, W, H, 1.0f, 4095, 4095))
        return 1;
    uint8_t *table = make_moebius(&moeb);

    double t_copy = time_frames(frame_memcpy, NULL, reps), t_copy_frame = time_frames(frame_memcpy_whole, NULL, reps);
    double k_id = time_frames(frame_kernel, &ident, reps), k_mo = time_frames(frame_kernel, &moeb, reps);
    double r_id = time_frames(frame_readout, &ident, reps), r_mo = time_frames(frame_readout, &moeb, reps);
    printf("READOUT row path, %dx%d frame, best of %d (ns/pixel; speed relative to memcpy of the raw row)\n", W, H,
           reps);
    printf("  memcpy of the raw row        %7.3f ns/px  1.00  (row by row, cache-hot)\n", t_copy);
    printf("  memcpy of the raw frame      %7.3f ns/px  %.3f  (614 KB in one call)\n", t_copy_frame,
           t_copy / t_copy_frame);
    printf("  kernel, identity             %7.3f ns/px  %.3f\n", k_id, t_copy / k_id);
    printf("  kernel, Moebius              %7.3f ns/px  %.3f\n", k_mo, t_copy / k_mo);
    printf("  row path, identity           %7.3f ns/px  %.3f  (kernel + ROW frame + CRC)\n", r_id, t_copy / r_id);
    printf("  row path, Moebius            %7.3f ns/px  %.3f  (+ row block copy as from flash)\n", r_mo,
           t_copy / r_mo);
    printf("  Moebius frame time           %7.3f ms (640x480 at 20 us/row reads out in 9.6 ms)\n", r_mo * W * H * 1e-6);
    free(table);
    return keep == 0xdeadbeef;
}
