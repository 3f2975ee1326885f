/* End-to-end simulated capture of 640x480 frames: the firmware on the simulated HAL in one
 * thread serving its socket, the host's protocol client in another, the default scene with its
 * own effects. Prints frames/s end to end, and beside it, in the same run, the simulator alone
 * rendering the same frames (wdr_sim_render): the share of the time the rest of the chain takes
 * (firmware state machine, correction, framing, socket, client). Target: >= 10 frames/s.
 * No assertion on time. --quick: a few frames, for CI. */
#include "bench_board.h"
#include "bench_util.h"
#include "board.h"
#include "hal.h"
#include "hal_sim_emul.h"
#include "operators.h"
#include "ramp.h"
#include "transport.h"
#include "transport_client.h"
#include "wdr_err.h"
#include "wdr_scene.h"
#include "wdr_sim.h"
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

static int die(const char *what, const char *why) { return bench_die("bench_capture", what, why); }

static int reinhard_lut(const wdr_board *b, uint8_t **bytes, size_t *len)
{
    static wdr_operator op;
    wdr_lum_stats st;
    wdr_ideal_pixel px;
    wdr_ramp ramp;
    char err[512];
    wdr_lum_stats_default(b->i_min_a, b->i_center_a, b->i_max_a, b->lum_per_amp, 0.18, &st);
    wdr_ideal_pixel_init(b, &px);
    if (wdr_operator_init(&op, "reinhard", &st, err, sizeof err) != WDR_OK ||
        wdr_ramp_build(&px, &op, b->i_min_a, b->i_max_a, 8192, WDR_RAMP_FAIL, &ramp, err, sizeof err) != WDR_OK)
        return die("ramp", err);
    int rc = wdr_ramp_quantise(&ramp, b, &op, b->dac_timing, b->dac_uniform_entries, bytes, len, err, sizeof err);
    wdr_ramp_free(&ramp);
    return rc == WDR_OK ? 0 : die("LUT", err);
}

/* The simulator alone, on its own chip with the same scene and LUT: the floor of the chain. */
static double sim_only_fps(const wdr_board *b, const uint8_t *lut, size_t lut_len, int frames)
{
    char err[512];
    wdr_scene sc;
    wdr_lut_view view;
    wdr_sim *s = wdr_sim_create(b, 1);
    uint16_t *frame = malloc((size_t)b->width * b->height * sizeof *frame);
    if (!s || !frame || wdr_scene_load(WDR_SOURCE_DIR "/sim/scenes/window.json", b, &sc, err, sizeof err) != WDR_OK)
        return 0;
    wdr_scene_apply(&sc, s);
    wdr_scene_free(&sc);
    wdr_lut_parse(lut, lut_len, &view);
    wdr_sim_set_lut(s, &view);
    double t0 = now_s();
    for (int k = 0; k < frames; k++)
        wdr_sim_render(s, (uint64_t)k, frame);
    double t = now_s() - t0;
    free(frame);
    wdr_sim_destroy(s);
    return t > 0 ? frames / t : 0;
}

static int measure(const char *address, const wdr_board *b, const uint8_t *lut, size_t lut_len, int frames)
{
    char err[512];
    wdr_transport *t;
    wdr_client *c = calloc(1, sizeof *c);
    uint16_t *codes = malloc((size_t)b->width * b->height * sizeof *codes);
    c->timeout_ms = 10000;
    c->retries = WDR_CLIENT_RETRIES;
    if (wdr_transport_open(address, &t, err, sizeof err) != WDR_OK)
        return die("connect", err);
    if (wdr_client_connect(c, t) != WDR_OK || wdr_client_upload(c, WDR_KIND_LUT, lut, lut_len, NULL, NULL, NULL) != WDR_OK ||
        wdr_client_capture(c, 1, codes, NULL, NULL) != WDR_OK) /* warm-up: first frame builds the sim's tables */
        return die("board", c->err);
    double t0 = now_s();
    int rc = wdr_client_capture(c, (uint32_t)frames, codes, NULL, NULL);
    double secs = now_s() - t0;
    if (rc != WDR_OK)
        return die("capture", c->err);
    double e2e = frames / secs, alone = sim_only_fps(b, lut, lut_len, frames);
    printf("end-to-end capture, %ux%u, %d frames: %.1f frames/s (%.1f ms/frame; target >= 10)\n", b->width,
           b->height, frames, e2e, 1000.0 / e2e);
    printf("simulator alone, same scene and LUT: %.1f frames/s (%.1f ms/frame)\n", alone, 1000.0 / alone);
    printf("rest of the chain (firmware, correction, framing, socket, client): %.1f ms/frame, %.0f %% of the total\n",
           1000.0 / e2e - 1000.0 / alone, 100.0 * (1.0 - e2e / alone));
    wdr_transport_close(t);
    free(codes);
    free(c);
    return 0;
}

int main(int argc, char **argv)
{
    int quick = argc > 1 && !strcmp(argv[1], "--quick");
    int frames = quick ? 5 : 50;
    char dir[] = "/tmp/wdr-bench-XXXXXX", address[160];
    wdr_board b;
    pthread_t th;
    uint8_t *lut = NULL;
    size_t lut_len = 0;
    const char *scene = WDR_SOURCE_DIR "/sim/scenes/window.json";
    if (!mkdtemp(dir) || bench_start_board("bench_capture", &b, scene, dir, address, sizeof address, &th) != 0)
        return 1;
    int rc = reinhard_lut(&b, &lut, &lut_len);
    if (rc == 0)
        rc = measure(address, &b, lut, lut_len, frames);
    hal_sim_request_stop();
    pthread_join(th, NULL);
    hal_sim_teardown();
    rmdir(dir);
    free(lut);
    return rc;
}
