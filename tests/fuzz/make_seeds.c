/* Writes the generated part of the seed corpora (corpus/<target>/): tables built with the
 * formats' own encoders as the tests build them, files written by the project's writers and
 * stb_image_write, a good session per protocol harness, and every reproducer of issue 14.
 * Run once by hand (fuzz_make_seeds CORPUS_DIR); the output is committed. The real
 * scenes and the LUTs wdrctl builds are copied in by make_seeds.sh. */
#include "boot_test_util.h"
#include "crc32.h"
#include "fake_hal.h"
#include "image_io.h"
#include "make_seeds_image.h"
#include "table_builders.h"
#include "wdr_cal.h"
#include "wdr_lut.h"
#include "wdr_proto.h"
#define STB_IMAGE_WRITE_IMPLEMENTATION
#include <stb_image_write.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const char *root;

static void put(const char *target, const char *name, const void *data, size_t n)
{
    char path[1024];
    snprintf(path, sizeof path, "%s/%s/%s", root, target, name);
    FILE *f = fopen(path, "wb");
    if (!f || fwrite(data, 1, n, f) != n || fclose(f)) {
        fprintf(stderr, "make_seeds: cannot write %s\n", path);
        exit(1);
    }
}

/* ---- a growing byte buffer for record-shaped inputs ---- */
static uint8_t rec[1 << 20];
static size_t rec_n;

static void rec_bytes(const void *p, size_t n)
{
    memcpy(rec + rec_n, p, n);
    rec_n += n;
}

static void rec_u8(uint8_t v) { rec_bytes(&v, 1); }

static void rec_u16(uint16_t v)
{
    uint8_t b[2] = {(uint8_t)v, (uint8_t)(v >> 8)};
    rec_bytes(b, 2);
}

/* ---- tables ---- */
static _Alignas(4) uint8_t lut[65536], cal[1 << 20], basis[1 << 20], wrapped[1 << 20];
static size_t lut_n, cal_n, basis_n, wrapped_n;

static size_t steep_lut(uint8_t *out)
{
    uint32_t t[10];
    uint16_t c[10];
    for (int i = 0; i < 10; i++)
        t[i] = (uint32_t)i, c[i] = (uint16_t)(3 * i);
    wdr_lut_header h;
    memset(&h, 0, sizeof h);
    h.dac_bits = 12;
    h.entry_count = 10;
    h.tick_ps = 1000;
    h.t_integration_ticks = 100;
    h.dac_hi_v = 4.095f;
    wdr_lut_encode(&h, t, c, out);
    return wdr_lut_size(10);
}

static void tables(void)
{
    lut_n = th_make_lut(lut, 256, 0, 12);
    cal_n = th_make_cal(cal, 0.5f, 3.0f, 77, 64, 48);
    basis_n = th_make_cal_basis(basis, 77, 64, 48, 0);
    wrapped_n = th_make_cal_wrapped(wrapped, 77, 64, 48);
    put("lut", "th_lut_256", lut, lut_n);
    static uint8_t l2[65536];
    put("lut", "th_lut_1000_dac10", l2, th_make_lut(l2, 1000, 7, 10));
    put("lut", "repro_steep_end_extend", l2, steep_lut(l2));
    put("cal", "th_moebius_64x48", cal, cal_n);
    put("cal", "th_basis_64x48", basis, basis_n);
    static uint8_t c2[1 << 16];
    put("cal", "th_moebius_8x4", c2, th_make_cal(c2, 2.0f, 1.0f, 77, 8, 4));
    put("cal", "th_basis_nan_8x4", c2, th_make_cal_basis(c2, 77, 8, 4, 1));
    put("cal", "repro_shared_points_wrap", wrapped, wrapped_n);
    size_t small = th_make_cal_wrapped(c2, 77, 4, 2); /* the same fault on a 4x2 table */
    put("cal", "repro_shared_points_wrap_4x2", c2, small);
}

/* ---- fw_rx: requests as records, and raw frames ---- */
static void req(uint8_t op, const void *p, uint16_t n)
{
    rec_u8(op);
    rec_u16(n);
    rec_bytes(p, n);
}

static void upload_rec(int kind, const uint8_t *t, size_t n)
{
    rec_u8(0xff);
    rec_u16((uint16_t)(n + 1));
    rec_u8(kind == WDR_KIND_CAL);
    rec_bytes(t, n);
}

static void fw_rx(void)
{
    uint8_t ver[4] = {WDR_PROTO_VERSION_MAJOR, 0, WDR_PROTO_VERSION_MINOR, 0}, one[4] = {1, 0, 0, 0};
    uint8_t integ[4] = {0x40, 0x42, 0x0f, 0}, on = 1, off = 0, newest = WDR_SLOT_NEWEST;
    rec_n = 0;
    rec_u8(1);
    req(WDR_CMD_INFO, ver, 4);
    req(WDR_CMD_STATUS, NULL, 0);
    req(WDR_CMD_CAPTURE, one, 4);
    req(WDR_CMD_SET_INTEGRATION, integ, 4);
    req(WDR_CMD_CAPTURE, one, 4);
    req(WDR_CMD_LUT_SELECT, &newest, 1);
    req(WDR_CMD_STREAM, &on, 1);
    req(WDR_CMD_STREAM, &off, 1);
    req(WDR_CMD_ABORT, NULL, 0);
    put("fw_rx", "session_requests", rec, rec_n);
    rec_n = 0;
    rec_u8(1);
    upload_rec(WDR_KIND_LUT, lut, lut_n);
    upload_rec(WDR_KIND_CAL, basis, basis_n > 60000 ? 0 : basis_n);
    req(WDR_CMD_CAPTURE, one, 4);
    put("fw_rx", "session_uploads", rec, rec_n);
    rec_n = 0;
    rec_u8(1);
    upload_rec(WDR_KIND_CAL, wrapped, wrapped_n);
    req(WDR_CMD_CAPTURE, one, 4);
    put("fw_rx", "repro_commit_wrapped_cal", rec, rec_n);
    /* raw: the same requests as framed bytes, one garbled */
    static uint8_t raw[1 << 16];
    size_t n = 1;
    raw[0] = 0;
    wdr_proto_header h = {.opcode = WDR_CMD_INFO, .seq = 1};
    n += wdr_proto_encode(raw + n, sizeof raw - n, &h, ver, 4);
    h.opcode = WDR_CMD_STATUS, h.seq = 2;
    n += wdr_proto_encode(raw + n, sizeof raw - n, &h, NULL, 0);
    h.opcode = WDR_CMD_CAPTURE, h.seq = 3;
    size_t at = n;
    n += wdr_proto_encode(raw + n, sizeof raw - n, &h, one, 4);
    put("fw_rx", "raw_frames", raw, n);
    raw[at + 9] ^= 0x10;
    put("fw_rx", "raw_frames_garbled", raw, n);
    /* the update commands (1.4), in front of any image */
    uint8_t begin[8] = {0x00, 0x01, 0, 0, 0x78, 0x56, 0x34, 0x12}, chunk[4 + 64] = {0};
    rec_n = 0;
    rec_u8(1);
    req(WDR_CMD_FW_STATUS, NULL, 0);
    req(WDR_CMD_FW_BEGIN, begin, sizeof begin);
    req(WDR_CMD_FW_CHUNK, chunk, sizeof chunk);
    req(WDR_CMD_FW_COMMIT, NULL, 0);
    req(WDR_CMD_FW_CONFIRM, NULL, 0);
    req(WDR_CMD_FW_REVERT, NULL, 0);
    req(WDR_CMD_REBOOT, NULL, 0);
    req(WDR_CMD_STATUS, NULL, 0);
    put("fw_rx", "session_fw_requests", rec, rec_n);
}

/* ---- fw_update: images signed with the development key, in update sessions ---- */
static void rec_u32(uint32_t v)
{
    rec_u16((uint16_t)v);
    rec_u16((uint16_t)(v >> 16));
}

static uint8_t *signed_image(const bt_key *key, uint8_t major, uint32_t counter, const char *board, size_t *n)
{
    bt_image_spec s = bt_spec(major, counter, 512);
    s.board = board;
    s.flags |= WDR_IMAGE_F_DEV_KEY;
    uint8_t *img = malloc(1024);
    *n = bt_image_build(img, 1024, &s, key, NULL);
    return img;
}

static void image_rec(uint8_t op, const uint8_t *img, size_t n)
{
    rec_u8(op);
    rec_u16((uint16_t)n);
    rec_bytes(img, n);
}

static void fw_update(void)
{
    bt_key key;
    bt_key_dev(&key);
    size_t n1, n2, n3;
    uint8_t *v1 = signed_image(&key, 1, 1, FB_BOARD_NAME, &n1), *v2 = signed_image(&key, 2, 2, FB_BOARD_NAME, &n2);
    uint8_t *other = signed_image(&key, 3, 2, "other-board", &n3);
    rec_n = 0; /* upload, test boot, confirm, reboot */
    rec_u8(0);
    image_rec(0, v1, n1);
    image_rec(1, v2, n2);
    rec_u8(8), rec_u8(5), rec_u8(6), rec_u8(8), rec_u8(5);
    put("fw_update", "upload_confirm", rec, rec_n);
    rec_n = 0; /* never confirmed: back to v1 after the attempts; a revert after another upload */
    rec_u8(0);
    image_rec(0, v1, n1);
    image_rec(1, v2, n2);
    rec_u8(8), rec_u8(8), rec_u8(8), rec_u8(8), rec_u8(5);
    image_rec(1, v2, n2);
    rec_u8(8), rec_u8(7), rec_u8(8), rec_u8(5);
    put("fw_update", "unconfirmed_and_revert", rec, rec_n);
    rec_n = 0; /* by hand: BEGIN, chunks out of order and in order, COMMIT; while streaming */
    rec_u8(0);
    image_rec(0, v1, n1);
    rec_u8(2), rec_u32((uint32_t)n2), rec_u32(wdr_crc32(0, v2, n2));
    rec_u8(3), rec_u32(100), rec_u16(16), rec_bytes(v2 + 100, 16);
    rec_u8(3), rec_u32(0), rec_u16((uint16_t)n2), rec_bytes(v2, n2);
    rec_u8(10), rec_u8(1), rec_u8(4), rec_u8(10), rec_u8(0), rec_u8(4), rec_u8(5);
    put("fw_update", "chunks_by_hand", rec, rec_n);
    rec_n = 0; /* refusals: another board, a flipped byte, a truncated image */
    rec_u8(0);
    image_rec(0, v1, n1);
    image_rec(1, other, n3);
    v2[200] ^= 1;
    image_rec(1, v2, n2);
    v2[200] ^= 1;
    image_rec(1, v2, n2 - 16);
    rec_u8(5);
    put("fw_update", "refusals", rec, rec_n);
    free(v1), free(v2), free(other);
}

/* ---- boot: tables sealed into slots, then pokes ---- */
static void table_rec(int kind, const uint8_t *t, size_t n)
{
    rec_u8(0);
    rec_u8(kind == WDR_KIND_CAL);
    rec_u16((uint16_t)n);
    rec_bytes(t, n);
}

static void poke_rec(uint32_t addr, const void *p, uint8_t n)
{
    rec_u8(1);
    rec_u16((uint16_t)(addr / 4));
    rec_u8(n);
    rec_bytes(p, n);
}

static void boot(void)
{
    rec_n = 0;
    table_rec(WDR_KIND_LUT, lut, lut_n);
    table_rec(WDR_KIND_CAL, cal, cal_n);
    put("boot", "lut_and_cal", rec, rec_n);
    rec_n = 0;
    table_rec(WDR_KIND_LUT, lut, lut_n);
    table_rec(WDR_KIND_LUT, lut, lut_n);
    table_rec(WDR_KIND_CAL, cal, cal_n);
    uint8_t zero[16] = {0};
    poke_rec(0, zero, 16); /* a torn first slot header */
    put("boot", "two_luts_torn_header", rec, rec_n);
    rec_n = 0;
    table_rec(WDR_KIND_LUT, lut, lut_n);
    table_rec(WDR_KIND_CAL, wrapped, wrapped_n);
    put("boot", "repro_stored_wrapped_cal", rec, rec_n);
}

/* ---- images ---- */
static size_t exr_with_window(uint8_t *out, int32_t max_x, int32_t max_y); /* below */

static void images(void)
{
    char path[1024];
    float rgb[3 * 16 * 8], grey[16 * 8];
    for (int i = 0; i < 16 * 8; i++)
        rgb[3 * i] = (float)i * 0.5f, rgb[3 * i + 1] = 1e-3f * (float)i, rgb[3 * i + 2] = 100.0f, grey[i] = (float)i;
    snprintf(path, sizeof path, "%s/images/rle_16x8.hdr", root);
    stbi_write_hdr(path, 16, 8, 3, rgb);
    snprintf(path, sizeof path, "%s/images/flat_4x3.hdr", root);
    stbi_write_hdr(path, 4, 3, 3, rgb);
    char err[256];
    snprintf(path, sizeof path, "%s/images/grey_16x8.pfm", root);
    wdr_pfm_write(path, grey, 16, 8, err, sizeof err);
    static uint8_t f[4096];
    put("images", "y_1x1.exr", f, exr_with_window(f, 0, 0));
    put("images", "repro_exr_huge_window.exr", f, exr_with_window(f, 99999, 99999));
    put("images", "repro_exr_tall_window.exr", f, exr_with_window(f, 7999, 7999));
    const char hdr_head[] = "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n";
    memset(f, 0, 375);
    size_t n = (size_t)snprintf((char *)f, sizeof f, "%s-Y 8 +X 16\n", hdr_head);
    const uint8_t marker[] = {2, 2, 0, 16, 0};
    memcpy(f + n, marker, sizeof marker);
    put("images", "repro_cve_2021_42715_zero_run.hdr", f, 375);
    n = (size_t)snprintf((char *)f, sizeof f, "%s-Y 20 +X 0\n", hdr_head);
    put("images", "repro_zero_width.hdr", f, n);
    n = (size_t)snprintf((char *)f, sizeof f, "%s-Y 6000000 +X 20\n", hdr_head);
    put("images", "repro_6000000x20.hdr", f, n);
    n = (size_t)snprintf((char *)f, sizeof f, "Pf\n65536 65536\n-1.0\n");
    put("images", "repro_65536x65536.pfm", f, n + 8);
}

/* ---- client: a good session of replies, and the bad INFOs ---- */
static void reply(uint8_t status, const void *p, uint16_t n)
{
    rec_u8(1);
    rec_u16((uint16_t)(n + 1));
    rec_u8(status);
    rec_bytes(p, n);
}

static void info_reply(uint16_t w, uint16_t h, uint8_t adc)
{
    wdr_info info = {.proto_major = WDR_PROTO_VERSION_MAJOR, .proto_minor = WDR_PROTO_VERSION_MINOR, .fw_major = 1,
                     .sensor_id = 77, .width = w, .height = h, .adc_bits = adc, .dac_bits = 12,
                     .max_payload = WDR_PROTO_MAX_PAYLOAD, .lut_capacity = 1 << 16, .cal_capacity = 1 << 20,
                     .row_time_ns = 1000};
    strcpy(info.name, "seed");
    uint8_t p[WDR_INFO_SIZE];
    wdr_info_pack(&info, p);
    reply(WDR_ST_OK, p, sizeof p);
}

static void status_reply(void)
{
    wdr_status_report s = {.lut_slot = 0, .cal_slot = WDR_SLOT_NONE, .integration_ns = 1000000};
    uint8_t p[WDR_STATUS_SIZE];
    wdr_status_pack(&s, p);
    reply(WDR_ST_OK, p, sizeof p);
}

static void frame_events(uint32_t frame, uint16_t w, uint16_t h)
{
    for (uint16_t r = 0; r < h; r++) {
        uint8_t p[1 + WDR_PROTO_ROW_HEADER + 2 * 16];
        p[0] = 1; /* ROW */
        wdr_put_u32(p + 1, frame);
        wdr_put_u16(p + 5, r);
        wdr_put_u16(p + 7, w);
        for (uint16_t i = 0; i < w; i++)
            wdr_put_u16(p + 1 + WDR_PROTO_ROW_HEADER + 2 * i, (uint16_t)(r * w + i));
        rec_u8(2);
        rec_u16((uint16_t)(1 + WDR_PROTO_ROW_HEADER + 2 * w));
        rec_bytes(p, 1 + WDR_PROTO_ROW_HEADER + 2u * w);
    }
    wdr_frame_end e = {.frame = frame, .rows = h, .integration_ns = 1000000};
    uint8_t p[1 + WDR_FRAME_END_SIZE];
    p[0] = 0;
    wdr_frame_end_pack(&e, p + 1);
    rec_u8(2);
    rec_u16(sizeof p);
    rec_bytes(p, sizeof p);
}

static void client(void)
{
    rec_n = 0;
    info_reply(16, 8, 12);
    status_reply();
    reply(WDR_ST_OK, NULL, 0); /* BEGIN */
    reply(WDR_ST_OK, NULL, 0); /* CHUNK */
    reply(WDR_ST_OK, NULL, 0); /* CHUNK */
    static uint8_t table[6000];
    wdr_commit_reply c = {.crc = wdr_crc32(0, table, sizeof table), .seq = 1, .slot = 0};
    uint8_t cp[WDR_COMMIT_REPLY_SIZE];
    wdr_commit_pack(&c, cp);
    reply(WDR_ST_OK, cp, sizeof cp);
    status_reply(); /* frame timeout */
    reply(WDR_ST_OK, NULL, 0); /* CAPTURE */
    frame_events(0, 16, 8);
    frame_events(1, 16, 8);
    status_reply();
    reply(WDR_ST_OK, NULL, 0); /* STREAM on */
    frame_events(2, 16, 8);
    frame_events(3, 16, 8);
    reply(WDR_ST_OK, NULL, 0); /* STREAM off */
    status_reply();
    put("client", "good_session", rec, rec_n);
    size_t upto_stream = rec_n;
    (void)upto_stream;
    rec_n = 0;
    info_reply(16, 8, 40);
    put("client", "repro_info_adc_bits_40", rec, rec_n);
    rec_n = 0;
    info_reply(16, 8, 0);
    put("client", "repro_info_adc_bits_0", rec, rec_n);
    rec_n = 0;
    info_reply(0, 0, 12);
    put("client", "repro_info_0x0_sensor", rec, rec_n);
    /* the board hangs up once the stream is on: the stream's callback must not outlive it */
    rec_n = 0;
    info_reply(16, 8, 12);
    status_reply();
    reply(WDR_ST_BAD_ARG, NULL, 0); /* BEGIN refused, then an ABORT answer */
    reply(WDR_ST_OK, NULL, 0);
    status_reply();
    reply(WDR_ST_OK, NULL, 0); /* CAPTURE */
    frame_events(0, 16, 8);
    frame_events(1, 16, 8);
    status_reply();
    reply(WDR_ST_OK, NULL, 0); /* STREAM on, then the input ends: a hang-up */
    put("client", "repro_stream_hangup", rec, rec_n);
}

int main(int argc, char **argv)
{
    if (argc != 2) {
        fprintf(stderr, "usage: fuzz_make_seeds CORPUS_DIR\n");
        return 64;
    }
    root = argv[1];
    tables();
    fw_rx();
    fw_update();
    boot();
    images();
    client();
    make_image_seeds(put);
    return 0;
}

/* A 1x1 scanline EXR (uncompressed half Y) with the data window given: as in test_reader_faults.c. */
static size_t exr_with_window(uint8_t *out, int32_t max_x, int32_t max_y)
{
    size_t n = 0;
#define PUT(p, len) (memcpy(out + n, (p), (len)), n += (len))
#define PUT32(v)                                                                                                       \
    do {                                                                                                               \
        int32_t v_ = (v);                                                                                              \
        PUT(&v_, 4);                                                                                                   \
    } while (0)
    const uint8_t magic[] = {0x76, 0x2f, 0x31, 0x01, 2, 0, 0, 0};
    float one = 1.0f, zero2[2] = {0, 0};
    PUT(magic, sizeof magic);
    PUT("channels\0chlist\0", 16);
    PUT32(19);
    PUT("Y\0", 2);
    PUT32(1);
    PUT("\0\0\0\0", 4);
    PUT32(1);
    PUT32(1);
    PUT("\0", 1);
    PUT("compression\0compression\0", 24);
    PUT32(1);
    PUT("\0", 1);
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
    PUT("\0", 1);
    PUT("pixelAspectRatio\0float\0", 23);
    PUT32(4);
    PUT(&one, 4);
    PUT("screenWindowCenter\0v2f\0", 23);
    PUT32(8);
    PUT(zero2, 8);
    PUT("screenWindowWidth\0float\0", 24);
    PUT32(4);
    PUT(&one, 4);
    PUT("\0", 1);
    uint64_t offset = n + 8;
    PUT(&offset, 8);
    PUT32(0);
    PUT32(2);
    PUT("\0\x3c", 2);
    return n;
#undef PUT32
#undef PUT
}
