/* Simulator speed: a 1920x1080 frame of the default window scene (six decades) through a
 * Reinhard LUT, (a) ideal pixel + mismatch (with DAC/ADC quantisation and clipping) and
 * (b) every effect, on one thread and on all cores: ns/pixel, speed-up, parallel efficiency;
 * and `auto` against every effect on for each bundled scene. Targets (issue 3): (a) <= 10,
 * (b) <= 50 ns/pixel on one core, >= 80 % efficiency on 2 cores. --quick: 320x180. */
#include "wdr_err.h"
#include "wdr_scene.h"
#include "ramp.h"
#include "wdr_sim.h"
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#ifndef WDR_SOURCE_DIR
#define WDR_SOURCE_DIR "."
#endif

static double now(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return t.tv_sec + 1e-9 * t.tv_nsec;
}

/* Best of reps renders, in ns per pixel: the machine is shared, the minimum is the cleanest. */
static double ns_per_pixel(wdr_sim *s, int threads, int reps, uint16_t *frame)
{
    const wdr_board *b = wdr_sim_board(s);
    double best = 1e30;
    wdr_sim_set_threads(s, threads);
    for (int r = 0; r < reps; r++) {
        double t0 = now();
        if (wdr_sim_render(s, 1 + r, frame))
            return -1;
        best = best < now() - t0 ? best : now() - t0;
    }
    return best * 1e9 / ((double)b->width * b->height);
}

static void set_effects(wdr_sim *s, int every)
{
    for (int fx = 0; fx < WDR_FX_COUNT; fx++)
        wdr_sim_set_effect(s, fx, every ? WDR_FX_ON : WDR_FX_OFF);
    if (!every) {
        int ideal[] = {WDR_FX_MISMATCH, WDR_FX_DAC_QUANT, WDR_FX_ADC_QUANT, WDR_FX_CLIPPING};
        for (int k = 0; k < 4; k++)
            wdr_sim_set_effect(s, ideal[k], WDR_FX_ON);
    }
}

static int load_scene(const char *name, const wdr_board *b, wdr_scene *sc)
{
    char path[1024], err[1024];
    snprintf(path, sizeof path, "%s/sim/scenes/%s.json", WDR_SOURCE_DIR, name);
    int rc = wdr_scene_load(path, b, sc, err, sizeof err);
    if (rc)
        fprintf(stderr, "bench_sim: %s\n", err);
    return rc;
}

static int bench_modes(wdr_sim *s, int reps, int cores, uint16_t *frame)
{
    const char *label[2] = {"(a) ideal + mismatch", "(b) every effect   "};
    const double target[2] = {10, 50};
    for (int every = 0; every < 2; every++) {
        set_effects(s, every);
        double one = ns_per_pixel(s, 1, reps, frame), all = ns_per_pixel(s, cores, reps, frame);
        if (one < 0 || all < 0)
            return 1;
        printf("%s  1 thread %6.2f ns/px (target %2.0f: %s)   %d threads %6.2f ns/px   speed-up %.2f, "
               "efficiency %3.0f %%\n", label[every], one, target[every], one <= target[every] ? "met" : "missed",
               cores, all, one / all, 100 * one / all / cores);
    }
    return 0;
}

static int bench_auto(const wdr_board *b, int reps, int cores, uint16_t *frame)
{
    const char *scenes[] = {"window", "log_wedge", "step_chart", "uniform"};
    for (int k = 0; k < 4; k++) {
        wdr_scene sc;
        if (load_scene(scenes[k], b, &sc))
            return 1;
        uint8_t *bytes;
        size_t len;
        char err[512];
        wdr_lut_view lut;
        wdr_sim *s = wdr_sim_create(b, sc.chip_seed);
        if (!s || wdr_ramp_board_lut(b, "reinhard", &bytes, &len, NULL, err, sizeof err) ||
            wdr_lut_parse(bytes, len, &lut) || wdr_sim_set_lut(s, &lut) || wdr_scene_apply(&sc, s))
            return fprintf(stderr, "bench_sim: set-up failed for %s\n", scenes[k]), 1;
        double t_auto = ns_per_pixel(s, cores, reps, frame);
        int skipped = 0;
        for (int fx = 0; fx < WDR_FX_COUNT; fx++)
            skipped += !wdr_sim_report(s)[fx].ran;
        set_effects(s, 1);
        double t_on = ns_per_pixel(s, cores, reps, frame);
        printf("auto vs every effect on, %-10s: %5.2f vs %5.2f ns/px, ratio %.2f (%d effects skipped%s)\n",
               scenes[k], t_auto, t_on, t_on / t_auto, skipped, sc.reference ? ", reference frame" : "");
        wdr_sim_destroy(s);
        free(bytes);
        wdr_scene_free(&sc);
    }
    return 0;
}

int main(int argc, char **argv)
{
    int quick = argc > 1 && !strcmp(argv[1], "--quick");
    wdr_board b;
    wdr_board_defaults(&b);
    b.width = quick ? 320 : 1920;
    b.height = quick ? 180 : 1080;
    int reps = quick ? 2 : 5;
    long cores = sysconf(_SC_NPROCESSORS_ONLN);
    int n_cores = cores > 0 ? (int)cores : 1;
    wdr_scene sc;
    uint8_t *bytes;
    size_t len;
    char err[512];
    wdr_lut_view lut;
    uint16_t *frame = malloc((size_t)b.width * b.height * sizeof *frame);
    if (!frame || load_scene("window", &b, &sc))
        return 1;
    if (wdr_ramp_board_lut(&b, "reinhard", &bytes, &len, NULL, err, sizeof err) || wdr_lut_parse(bytes, len, &lut))
        return fprintf(stderr, "bench_sim: LUT: %s\n", err), 1;
    double t0 = now();
    wdr_sim *s = wdr_sim_create(&b, 1);
    if (!s || wdr_sim_set_lut(s, &lut) || wdr_scene_apply(&sc, s))
        return fprintf(stderr, "bench_sim: set-up failed\n"), 1;
    printf("bench_sim: %dx%d window scene (%.0e..%.0e A), Reinhard LUT of %u entries, %d cores; chip drawn in "
           "%.2f s\n", b.width, b.height, sc.i_min, sc.i_max, lut.h.entry_count, n_cores, now() - t0);
    int rc = bench_modes(s, reps, n_cores, frame);
    wdr_sim_destroy(s);
    wdr_scene_free(&sc);
    if (!rc)
        rc = bench_auto(&b, reps, n_cores, frame);
    free(bytes);
    free(frame);
    return rc;
}
