/* Upload throughput over the socket to the simulated board: a full LUT and a VGA calibration
 * table (polynomial, 2 coefficients per pixel), each through BEGIN, 4 KiB chunks with one
 * answer each, COMMIT with read-back CRC, and the board's flash programming behind it. Beside
 * them, in the same run, the same bytes pushed through a bare socketpair: the link's ceiling.
 * Prints MB/s; no assertion on time. --quick: fewer repetitions, for CI. */
#include "bench_board.h"
#include "bench_util.h"
#include "board.h"
#include "hal.h"
#include "hal_sim_emul.h"
#include "transport.h"
#include "transport_client.h"
#include "wdr_cal.h"
#include "wdr_err.h"
#include "wdr_fw_config.h"
#include "wdr_sim.h"
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <sys/socket.h>
#include <unistd.h>

static int die(const char *what, const char *why) { return bench_die("bench_upload", what, why); }

/* A LUT of the largest size the firmware keeps: a uniform ramp, one step per tick. */
static uint8_t *big_lut(const wdr_board *b, size_t *len)
{
    uint32_t n = WDR_FW_LUT_MAX_ENTRIES;
    uint32_t *t = malloc(n * sizeof *t);
    uint16_t *codes = malloc(n * sizeof *codes);
    *len = wdr_lut_size(n);
    uint8_t *out = malloc(*len);
    for (uint32_t i = 0; i < n; i++) {
        t[i] = i * 100;
        codes[i] = (uint16_t)((uint64_t)i * ((1u << b->dac_bits) - 1u) / (n - 1));
    }
    wdr_lut_header h = {.magic = WDR_LUT_MAGIC, .version_major = WDR_LUT_VERSION_MAJOR, .dac_bits = (uint8_t)b->dac_bits,
                        .timing = WDR_TIMING_UNIFORM, .entry_count = n, .tick_ps = 1000,
                        .t_integration_ticks = n * 100, .dac_lo_v = (float)b->dac_lo_v, .dac_hi_v = (float)b->dac_hi_v};
    wdr_lut_encode(&h, t, codes, out);
    free(t);
    free(codes);
    return out;
}

/* The identity polynomial v = y for every pixel: a real table of realistic size. */
static uint8_t *vga_cal(const wdr_board *b, size_t *len)
{
    size_t n = (size_t)b->width * b->height;
    float *coeffs = calloc(2 * n, sizeof *coeffs);
    uint8_t *flags = calloc(n, 1);
    for (size_t i = 0; i < n; i++)
        coeffs[n + i] = 1.0f;
    uint16_t full = (uint16_t)((1u << b->adc_bits) - 1u);
    wdr_cal_header h = {.sensor_id = b->sensor_id, .width = b->width, .height = b->height, .form = WDR_FORM_POLY,
                        .n_coeffs = 2, .in_scale = 1.0f, .out_scale = 1.0f, .out_max = full, .raw_max = full};
    *len = wdr_cal_size(b->width, b->height, 2);
    uint8_t *out = malloc(*len);
    wdr_cal_encode(&h, coeffs, flags, out);
    free(coeffs);
    free(flags);
    return out;
}

/* The same bytes through a bare socketpair, with a reader thread: no protocol, no flash. */
typedef struct sink_job {
    int fd;
    size_t want;
} sink_job;

static void *sink(void *arg)
{
    sink_job *j = arg;
    static uint8_t buf[65536];
    size_t got = 0;
    while (got < j->want) {
        ssize_t n = read(j->fd, buf, sizeof buf);
        if (n <= 0)
            break;
        got += (size_t)n;
    }
    return NULL;
}

static double raw_socket_mbps(const uint8_t *bytes, size_t len, int reps)
{
    int sv[2];
    wdr_transport *t;
    if (socketpair(AF_UNIX, SOCK_STREAM, 0, sv) != 0 || wdr_transport_from_fd(sv[0], "raw", &t) != WDR_OK)
        return 0;
    sink_job j = {.fd = sv[1], .want = len * (size_t)reps};
    pthread_t th;
    pthread_create(&th, NULL, sink, &j);
    double t0 = now_s();
    for (int r = 0; r < reps; r++)
        wdr_transport_send(t, bytes, len, 10000);
    pthread_join(th, NULL);
    double secs = now_s() - t0;
    wdr_transport_close(t);
    close(sv[1]);
    return secs > 0 ? (double)len * reps / secs / 1e6 : 0;
}

static int upload_mbps(wdr_client *c, int kind, const uint8_t *bytes, size_t len, int reps, double *mbps)
{
    double t0 = now_s();
    for (int r = 0; r < reps; r++)
        if (wdr_client_upload(c, kind, bytes, len, NULL, NULL, NULL) != WDR_OK)
            return die("upload", c->err);
    double secs = now_s() - t0;
    *mbps = secs > 0 ? (double)len * reps / secs / 1e6 : 0;
    return 0;
}

static int measure(const char *address, const wdr_board *b, int reps)
{
    char err[512];
    wdr_transport *t;
    wdr_client *c = calloc(1, sizeof *c);
    size_t lut_len, cal_len;
    uint8_t *lut = big_lut(b, &lut_len), *cal = vga_cal(b, &cal_len);
    double lut_mbps = 0, cal_mbps = 0;
    c->timeout_ms = 10000;
    c->retries = WDR_CLIENT_RETRIES;
    if (wdr_transport_open(address, &t, err, sizeof err) != WDR_OK)
        return die("connect", err);
    int rc = wdr_client_connect(c, t) == WDR_OK ? 0 : die("connect", c->err);
    if (rc == 0)
        rc = upload_mbps(c, WDR_KIND_LUT, lut, lut_len, reps * 4, &lut_mbps);
    if (rc == 0)
        rc = upload_mbps(c, WDR_KIND_CAL, cal, cal_len, reps, &cal_mbps);
    if (rc == 0) {
        double raw = raw_socket_mbps(cal, cal_len, reps);
        printf("LUT upload, %zu bytes x %d: %.1f MB/s\n", lut_len, reps * 4, lut_mbps);
        printf("calibration upload, %zu bytes x %d: %.1f MB/s\n", cal_len, reps, cal_mbps);
        printf("bare socketpair, same bytes: %.0f MB/s; the protocol's chunk round trips and flash programming "
               "reach %.1f %% of it\n", raw, raw > 0 ? 100.0 * cal_mbps / raw : 0.0);
        printf("retries needed: %u\n", c->retries_used);
    }
    wdr_transport_close(t);
    free(c);
    free(lut);
    free(cal);
    return rc;
}

int main(int argc, char **argv)
{
    int quick = argc > 1 && !strcmp(argv[1], "--quick");
    char dir[] = "/tmp/wdr-bench-XXXXXX", address[160];
    wdr_board b;
    pthread_t th;
    if (!mkdtemp(dir) || bench_start_board("bench_upload", &b, NULL, dir, address, sizeof address, &th) != 0)
        return 1;
    int rc = measure(address, &b, quick ? 1 : 5);
    hal_sim_request_stop();
    pthread_join(th, NULL);
    hal_sim_teardown();
    rmdir(dir);
    return rc;
}
