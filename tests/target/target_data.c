/* The host side of the target test: writes what QEMU's board replays and what wdrctl uploads,
 * and checks every captured pixel against the host build of the same firmware kernel.
 *
 *   target_data frames OUT W H N     replay file: N frames of raw 12-bit codes (every code 0..4095
 *                                    appears, rails included), in the layout hal/mps2 reads
 *   target_data lut OUT              a 12-bit stamped LUT
 *   target_data cal FORM OUT W H     a table of FORM (moebius, poly, basis, compact, shifted) for the board,
 *                                    with flagged pixels (single, runs, at both row ends)
 *   target_data check FRAMES CAL|none CAP.pfm...
 *                                    each capture must equal, to the bit, the host kernel's output
 *                                    for one replay frame (consecutive frames, as the board plays
 *                                    them); prints frames and pixels compared; exit 1 otherwise */
#include "mps2_board.h"
#include "correct.h"
#include "image_io.h"
#include "wdr_cal.h"
#include "wdr_lut.h"
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define RAW_MAX 4095u

static uint32_t rng_state = 12345u;
static uint32_t rng(void) /* xorshift32: reproducible, no libc state */
{
    rng_state ^= rng_state << 13, rng_state ^= rng_state >> 17, rng_state ^= rng_state << 5;
    return rng_state;
}
static float unit(void)
{
    return (float)(rng() >> 8) / 16777216.0f;
} /* [0, 1) */

static int write_file(const char *path, const void *p, size_t n)
{
    FILE *f = fopen(path, "wb");
    int ok = f && fwrite(p, 1, n, f) == n;
    if (f && fclose(f))
        ok = 0;
    if (!ok)
        fprintf(stderr, "target_data: cannot write %s\n", path);
    return ok ? 0 : 1;
}

static uint8_t *read_file(const char *path, size_t *n)
{
    FILE *f = fopen(path, "rb");
    uint8_t *p = NULL;
    long len = -1;
    if (f && !fseek(f, 0, SEEK_END) && (len = ftell(f)) >= 0 && !fseek(f, 0, SEEK_SET) &&
        (p = aligned_alloc(8, ((size_t)len + 8) & ~(size_t)7)) && fread(p, 1, (size_t)len, f) != (size_t)len) {
        free(p);
        p = NULL;
    }
    if (f)
        fclose(f);
    if (!p)
        fprintf(stderr, "target_data: cannot read %s\n", path);
    *n = (size_t)len;
    return p;
}

/* ---- replay frames ---- */

static int make_frames(const char *out, int w, int h, int n)
{
    size_t px = (size_t)w * h, len = 16 + 2 * px * (size_t)n;
    uint8_t *p = calloc(1, len);
    if (!p)
        return 1;
    wdr_put_u32(p, 0x4c505257u);
    wdr_put_u16(p + 4, (uint16_t)w);
    wdr_put_u16(p + 6, (uint16_t)h);
    wdr_put_u32(p + 8, (uint32_t)n);
    for (int f = 0; f < n; f++)
        for (size_t i = 0; i < px; i++) {
            uint32_t code = f == 0 ? (uint32_t)((i * 4096u) / px) : rng() % (RAW_MAX + 1u); /* frame 0: a sweep */
            wdr_put_u16(p + 16 + 2 * ((size_t)f * px + i), (uint16_t)code);
        }
    int rc = write_file(out, p, len);
    free(p);
    return rc;
}

static int make_lut(const char *out)
{
    enum { N = 4096 };
    static uint32_t t[N];
    static uint16_t codes[N];
    static uint8_t buf[WDR_LUT_HEADER_SIZE + N * WDR_LUT_ENTRY_SIZE];
    wdr_lut_header h = {.operator_id = WDR_OP_REINHARD,
                        .dac_bits = MPS2_DAC_BITS,
                        .timing = WDR_TIMING_STAMPED,
                        .entry_count = N,
                        .tick_ps = 1000,
                        .t_integration_ticks = N * 10u + 50u,
                        .dac_hi_v = 3.3f};
    for (uint32_t i = 0; i < N; i++)
        t[i] = i * 10u, codes[i] = (uint16_t)(RAW_MAX - i);
    wdr_lut_encode(&h, t, codes, buf);
    return write_file(out, buf, wdr_lut_size(N));
}

/* ---- tables ---- */

/* Flags: a lone pixel, a run of three, and both ends of some rows. */
static uint8_t flag_of(int w, int r, int c)
{
    return (r % 7 == 3 && c == w / 2) || (r % 11 == 5 && c >= 4 && c < 7) || (r % 13 == 2 && (c == 0 || c == w - 1))
               ? WDR_PIX_HOT
               : 0;
}

/* K points of n smooth shared functions: B0 the identity map in codes, the others bends. */
static void make_shared(float *shared, uint32_t K, int n)
{
    for (uint32_t j = 0; j < K; j++)
        for (int k = 0; k < n; k++) {
            float t = (float)j / (float)(K - 1);
            shared[j * (uint32_t)n + (uint32_t)k] =
                k == 0 ? t * (float)RAW_MAX : 40.0f * sinf((float)k * 3.0f * t) * expf(-2.0f * t * (float)k);
        }
}

static float coefficient(int form, int k, float y_scale)
{
    float d = unit() - 0.5f;
    switch (form) {
    case WDR_FORM_MOEBIUS: return k == 0 ? 1.0f + 0.05f * d : k == 1 ? 30.0f * d : 2e-5f * unit();
    case WDR_FORM_POLY: return k < 2 ? y_scale + 40.0f * d : 15.0f * d;
    default: return k == 0 ? 1.0f + 0.05f * d : 2.0f * d;
    }
}

static int make_cal(const char *name, const char *out, int w, int h)
{
    int form = !strcmp(name, "moebius")   ? WDR_FORM_MOEBIUS
               : !strcmp(name, "poly")    ? WDR_FORM_POLY
               : !strcmp(name, "basis")   ? WDR_FORM_BASIS
               : !strcmp(name, "compact") ? WDR_FORM_COMPACT
               : !strcmp(name, "shifted") ? WDR_FORM_SHIFTED
                                          : -1;
    if (form < 0)
        return fprintf(stderr, "target_data: unknown form '%s'\n", name), 2;
    int n = form == WDR_FORM_MOEBIUS ? 3 : form == WDR_FORM_POLY ? 5 : form == WDR_FORM_BASIS ? 8 : 4;
    uint32_t K = form == WDR_FORM_BASIS ? 512 : 1024;
    size_t np = (size_t)w * h;
    float *coeffs = malloc(sizeof(float) * np * (size_t)n), *shared = malloc(sizeof(float) * K * (size_t)n);
    uint8_t *flags = malloc(np),
            *buf = aligned_alloc(8, (wdr_cal_size_basis((uint16_t)w, (uint16_t)h, 8, K) + 7) & ~7u);
    uint32_t bad = 0;
    for (int r = 0; r < h; r++)
        for (int c = 0; c < w; c++) {
            size_t i = (size_t)r * w + c;
            bad += (flags[i] = flag_of(w, r, c)) != 0;
            if (form == WDR_FORM_SHIFTED) /* the pixel byte: 128 | flags, or a shift of -64..63 */
                flags[i] = flags[i] ? (uint8_t)(WDR_CAL_SHIFT_FLAGGED | flags[i]) : (uint8_t)((c * 37 + r) % 128);
            for (int k = 0; k < n; k++)
                coeffs[(size_t)k * np + i] = coefficient(form, k, RAW_MAX / 2.0f);
        }
    make_shared(shared, K, n);
    /* poly: 16-bit output, a scale that is no shift; the others the raw codes' range */
    wdr_cal_header hd = {.sensor_id = MPS2_SENSOR_ID,
                         .width = (uint16_t)w,
                         .height = (uint16_t)h,
                         .form = (uint16_t)form,
                         .n_coeffs = (uint16_t)n,
                         .model = WDR_MODEL_SPLINE,
                         .in_scale = 2.0f / RAW_MAX,
                         .in_offset = -1.0f,
                         .out_scale = form == WDR_FORM_POLY ? 15.9f : 1.0f,
                         .out_max = form == WDR_FORM_POLY ? 65535 : RAW_MAX,
                         .raw_max = RAW_MAX,
                         .bad_pixels = bad};
    size_t len;
    if (form == WDR_FORM_BASIS || wdr_cal_form_compact((uint16_t)form)) {
        hd.in_scale = (float)(K - 1) / RAW_MAX, hd.in_offset = 0.0f, hd.shared_points = K;
        if (form == WDR_FORM_BASIS)
            wdr_cal_encode_basis(&hd, shared, coeffs, flags, buf), len = wdr_cal_size_basis(hd.width, hd.height, 8, K);
        else
            wdr_cal_encode_compact(&hd, shared, coeffs, flags, buf), len = wdr_cal_size_compact(hd.width, hd.height, K);
    } else {
        wdr_cal_encode(&hd, coeffs, flags, buf);
        len = wdr_cal_size(hd.width, hd.height, (uint16_t)n);
    }
    wdr_cal_view v;
    int rc = wdr_cal_parse(buf, len, &v) ? (fprintf(stderr, "target_data: built %s table does not parse\n", name), 1)
                                         : write_file(out, buf, len);
    free(coeffs), free(shared), free(flags), free(buf);
    return rc;
}

/* ---- check ---- */

/* The table as the firmware activates it: BASIS and COMPACT tabulated per raw code. */
static int active_view(const char *path, uint8_t **buf, wdr_cal_view *v, int w, int h)
{
    static float basis_points[4096 * 8];
    static uint32_t compact_points[8192 * 4]; /* SHIFTED: one USAT a pixel (correct.c) */
    size_t len;
    if (!strcmp(path, "none"))
        return wdr_cal_identity(v, MPS2_SENSOR_ID, (uint16_t)w, (uint16_t)h, 1.0f, RAW_MAX, RAW_MAX);
    if (!(*buf = read_file(path, &len)) || wdr_cal_parse(*buf, len, v))
        return fprintf(stderr, "target_data: %s: not a table\n", path), 1;
    if (v->h.form == WDR_FORM_BASIS)
        return wdr_correct_per_code(v, basis_points, sizeof basis_points / sizeof(float));
    if (wdr_cal_form_compact(v->h.form))
        return wdr_correct_per_code_compact(v, compact_points, sizeof compact_points / sizeof(uint32_t));
    return 0;
}

/* Pixels of capture cap that differ from frame f's host output (exp). */
static long mismatches(const float *cap, const uint16_t *exp, size_t np)
{
    long bad = 0;
    for (size_t i = 0; i < np; i++)
        bad += cap[i] != (float)exp[i];
    return bad;
}

static int check(const char *frames_path, const char *cal_path, int ncap, char **caps)
{
    size_t len;
    uint8_t *fr = read_file(frames_path, &len), *tb = NULL;
    if (!fr)
        return 1;
    int w = wdr_get_u16(fr + 4), h = wdr_get_u16(fr + 6), nf = (int)wdr_get_u32(fr + 8);
    size_t np = (size_t)w * h;
    wdr_cal_view v;
    if (active_view(cal_path, &tb, &v, w, h))
        return 1;
    uint16_t *exp = malloc(sizeof(uint16_t) * np * (size_t)nf);
    for (int f = 0; f < nf; f++)
        for (int r = 0; r < h; r++)
            if (wdr_correct_row(&v, r, (const uint16_t *)(fr + 16) + ((size_t)f * h + r) * w,
                                exp + ((size_t)f * h + r) * w))
                return fprintf(stderr, "target_data: host kernel refused row %d\n", r), 1;
    int rc = 0, prev = -1;
    long pixels = 0;
    for (int c = 0; c < ncap; c++) {
        float *cap;
        int cw, ch;
        char err[256];
        if (wdr_pfm_read(caps[c], &cap, &cw, &ch, err, sizeof err) || cw != w || ch != h)
            return fprintf(stderr, "target_data: %s: %s\n", caps[c], cw != w ? "wrong size" : err), 1;
        int match = -1;
        long best = (long)np + 1;
        for (int f = 0; f < nf && match < 0; f++) {
            long bad = mismatches(cap, exp + (size_t)f * np, np);
            match = bad ? -1 : f;
            best = bad < best ? bad : best;
        }
        if (match < 0 || (prev >= 0 && match != (prev + 1) % nf)) {
            fprintf(stderr, "target_data: %s: %s (closest replay frame: %ld of %zu pixels differ)\n", caps[c],
                    match < 0 ? "no replay frame matches the host kernel's output" : "frames out of order", best, np);
            rc = 1;
        }
        prev = match;
        pixels += (long)np;
        free(cap);
    }
    printf("target_data: %s: %d frame(s), %ld pixels compared, %s\n", cal_path, ncap, pixels,
           rc ? "MISMATCH" : "all bit-identical to the host kernel");
    free(exp), free(fr), free(tb);
    return rc;
}

int main(int argc, char **argv)
{
    if (argc == 6 && !strcmp(argv[1], "frames"))
        return make_frames(argv[2], atoi(argv[3]), atoi(argv[4]), atoi(argv[5]));
    if (argc == 3 && !strcmp(argv[1], "lut"))
        return make_lut(argv[2]);
    if (argc == 6 && !strcmp(argv[1], "cal"))
        return make_cal(argv[2], argv[3], atoi(argv[4]), atoi(argv[5]));
    if (argc >= 5 && !strcmp(argv[1], "check"))
        return check(argv[2], argv[3], argc - 4, argv + 4);
    fprintf(stderr,
            "usage: target_data frames OUT W H N | lut OUT | cal FORM OUT W H | check FRAMES CAL|none CAP...\n");
    return 64;
}
