/* Auto exposure against the truth, on structured scenes (issue 19): wdr-simboard with the board's
 * realistic default (every effect "auto": mismatch, dark current, shot, kTC and read noise, droop,
 * both converters), calibrated on the board (`wdrctl calibrate --upload`, as the main job does), a
 * Reinhard LUT with its exposure table, SET_EXPOSURE auto from the LUT's own tick. Three scenes:
 * dark (the window scene 30x dimmer: the ramp must run 17x longer), bright (a step chart 30x
 * brighter, 55x the key: a tick of 18 ps, where a whole picosecond is 5.5 %) and HDR (a vertical
 * log wedge over seven decades: 18 % of it below the floor at the settled exposure). A fourth,
 * a window over ten decades (29 % past the floor, 12 % past the ceiling), is printed, not held:
 * what lies past both ends is a guess there (the censored tails are continued at the density seen
 * inside the limits, uniform in ln I, which fits a log gradient and not that scene's room). A
 * fifth, two halves e^4 apart, is printed when WDR_EXPO_SCENES names it: the key never settles there
 * (open; see scenes[]).
 *
 * The truth is the scene's log-average photocurrent counted as the software tone map counts it
 * (wdr_lum_stats_measure: every pixel's log, values at or below 1e-9 of the maximum at that guard),
 * from the photocurrents the scene puts on the sensor (the simulator's own map, not a frame). The
 * key the firmware settles on (the LUT's key times e^gain) must lie within 2 % of it (the dark
 * scene: DARK_TOLERANCE, below), and stay there from at most SETTLE_MAX frames on.
 *
 *   test_auto_exposure_scenes [BOARD [CHIP_SEED ...]]   (default sim-qvga, seed 1)
 * WDR_EXPO_EFFECTS='{"dark": "off", ...}' sets the scenes' effects (sim/scene.c's names), to split
 * an error by its causes; WDR_EXPO_CAL_FRAMES=none runs uncalibrated; WDR_EXPO_SCENES=hdr,dark runs only the
 * scenes named; WDR_EXPO_FORM=basis calibrates with another table form (default compact); WDR_EXPO_OP=drago
 * images and calibrates with another operator's LUT (default reinhard); WDR_EXPO_SCALE=0.5
 * makes every scene half as bright (the settled tick twice as long). */
#include "e2e_board.h"
#include "operators.h"
#include "ramp.h"
#include "wdr_err.h"
#include "wdr_scene.h"
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sysexits.h>
#include <unistd.h>

#define FRAMES 24
#define SETTLED_FROM 16 /* the settled key: the mean over frames 16..23 */
#define SETTLE_MAX 12   /* frames within which the key must be within TOLERANCE for good */
#define TOLERANCE 0.02
/* The dark scene's ramp runs 19.5x longer than its own.
 * Measured 2026-12-03, sim-qvga, seeds 1 / 2 / 3: +1.41 / +1.41 / +2.20 % (sim-vga seeds 1, 2:
 * +1.05 %), with three changes: the firmware takes out the dark current the longer hold adds
 * (the LUT's exposure block carries the board's mean dark current; +5.86 / +5.45 / +6.28 %
 * without), the exposure table reads codes at the middle row's read delay (the calibration's
 * corrected codes are the array median's; +2.20 / +2.20 / +3.01 % without) and the droop array
 * is computed again for the integration the calibration margin adds (wdrctl calibrate --lut).
 * Held at 2.5 %. Seen failing without the dark current taken out (seed 2: +4.63 %), and, on
 * seed 3's hdr scene, without the read delay (+1.87 %, worst late frame 2.27 %). Tried and not
 * kept: the exposure table's nodes fitted by least squares to each code's mean ln I (hdr went
 * from +1.87 to +4.18 %), and the damped step rounded instead of truncated (a limit cycle).
 * Later the same day: the censored tail's density band starts 0.5 ln inside the limit (sim-vga
 * hdr -2.84 / -3.93 % -> +0.29 / -0.49 %; e2e_auto_exposure_vga_hdr fails without it, -3.55 %),
 * and the step rule (wdr_fw_expo_step) closes a gap past 0.5 ln at once and takes a last 1/256
 * after two frames alike (seed 3's dark scene had stalled at +2.60 % until frame 13).
 * Stop 32: the exposure table follows the calibration's design (the droop from the crossing to
 * the integration's end, the dark current, each DAC step's code at the middle of its currents),
 * and a limit's value is read half a code inside it: dark +0.62 / +0.62 / +1.41 % (qvga seeds
 * 4, 5: +0.62 / +0.23 %; vga 1-3: +0.66 %). Now held at 2 %, as the other scenes; fails with the
 * old table (seed 3: +2.20 %). */
#define DARK_TOLERANCE 0.02

typedef struct scene_def {
    const char *name, *illumination;
    double exposure;
    double tolerance; /* what the test holds: 0 prints the figures only */
} scene_def;

static const scene_def scenes[] = {
    {"dark", "{\"pattern\": \"window\", \"l_min\": 1e-3, \"l_max\": 1e3, \"window\": [0.55, 0.15, 0.85, 0.6]}",
     1.0 / 30, DARK_TOLERANCE},
    {"bright", "{\"pattern\": \"step_chart\", \"l_min\": 0.1, \"l_max\": 1e3, \"columns\": 6, \"rows\": 4}", 1,
     TOLERANCE},
    {"hdr", "{\"pattern\": \"log_wedge\", \"l_min\": 1e-4, \"l_max\": 1e3, \"direction\": \"vertical\"}", 1, TOLERANCE},
    {"hdr10", "{\"pattern\": \"window\", \"l_min\": 1e-5, \"l_max\": 1e5, \"window\": [0.55, 0.15, 0.85, 0.6]}", 1, 0},
    /* two halves e^4 above and below the bright scene's log-average (a window 3000x the room): the
     * dark half lies just past the floor at the right key, with nothing in the density band, so the
     * firmware's tail spans its cap (8 ln) and the key never settles (tests/e2e/README.md). Printed. */
    {"halves", "{\"pattern\": \"step_chart\", \"l_min\": 0.183156, \"l_max\": 545.982, \"columns\": 2, \"rows\": 1}", 1,
     0},
};
#define N_SCENES (sizeof scenes / sizeof scenes[0])

typedef struct outcome {
    double truth_a, truth_dark_a, settled_a, error, worst_late;
    double below, above; /* fractions past the board's i_min and i_max at the settled exposure */
    double censored_dark, censored_bright; /* past the exposure table's floor and ceiling there (what the
                                            * firmware censors; Schlick's floor lies far above i_min) */
    int settle;          /* frames until the key stays within TOLERANCE; FRAMES + 1: never */
    unsigned held;       /* the last frame's STATUS exposure_flags, WDR_EXPO_HELD_* bits */
    double estimate;     /* the firmware's measured ln(L_avg / key) less the truth's, settled frames' mean */
} outcome;

/* The currents of the exposure table's floor and ceiling, at the LUT's own tick (its values are
 * ln(I / key_a)): the firmware censors the codes past them (as built, before calibrate's anchoring). */
static int table_limits(const uint8_t *lut, size_t len, double key_a, double *floor_a, double *ceiling_a)
{
    wdr_lut_view v;
    static wdr_lut_exposure ex;
    size_t end = wdr_lut_parse(lut, len, &v) ? len : wdr_lut_size(v.h.entry_count);
    if (end >= len || wdr_lut_exposure_parse(lut + end, len - end, &ex) != WDR_OK) {
        fprintf(stderr, "FAIL: the LUT built has no exposure table\n");
        return 1;
    }
    uint32_t floor_bin, ceiling_bin;
    wdr_lut_exposure_flat_ends(&ex, &floor_bin, &ceiling_bin);
    *floor_a = key_a * exp(ex.ln_q8[floor_bin] / 256.0);
    *ceiling_a = key_a * exp(ex.ln_q8[ceiling_bin] / 256.0);
    return 0;
}

/* The limit STATUS says holds the key short of the scene. */
static const char *held_name(unsigned flags)
{
    if (flags & WDR_EXPO_HELD_DAC_RATE)
        return "DAC rate";
    return flags & WDR_EXPO_HELD_INTEGRATION ? "integration" : "-";
}

/* An environment knob, or its default: read once, so a NULL never reaches a library call. */
static const char *env_or(const char *name, const char *fallback)
{
    const char *value = getenv(name);
    return value ? value : fallback;
}

/* What the test holds a scene to: its own tolerance, or for the dark scene WDR_EXPO_DARK_TOLERANCE
 * (a fraction) where an operator's dark end is known to reach less (e2e_auto_exposure_schlick). */
static double tolerance_of(const scene_def *d)
{
    const char *dark = env_or("WDR_EXPO_DARK_TOLERANCE", NULL);
    return dark && !strcmp(d->name, "dark") ? atof(dark) : d->tolerance;
}

static int write_scene(const char *path, const scene_def *d, unsigned long long seed)
{
    const char *effects = env_or("WDR_EXPO_EFFECTS", NULL);
    FILE *f = fopen(path, "w");
    if (!f)
        return -1;
    fprintf(f,
            "{\"format\": \"wdrcam-scene\", \"version\": 1, \"comment\": \"auto exposure: %s\",\n"
            " \"illumination\": %s,\n \"lum_to_amp\": 1e-11, \"exposure\": %.17g,\n"
            " \"chip_seed\": %llu, \"frame_seed\": %llu%s%s}\n",
            d->name, d->illumination, d->exposure * atof(env_or("WDR_EXPO_SCALE", "1")), seed, seed + 1000,
            effects ? ", \"effects\": " : "", effects ? effects : "");
    return fclose(f) ? -1 : 0;
}

/* The truth: log-average photocurrent of the scene's map, without and with the median dark current. */
static int scene_truth(const char *path, const wdr_board *b, outcome *o, float **amps, long *n)
{
    wdr_scene sc;
    wdr_lum_stats st;
    char err[512];
    if (wdr_scene_load(path, b, &sc, err, sizeof err) != WDR_OK) {
        fprintf(stderr, "%s\n", err);
        return -1;
    }
    *n = (long)sc.width * sc.height;
    *amps = sc.amps;
    sc.amps = NULL;
    wdr_scene_free(&sc);
    if (wdr_lum_stats_measure(*amps, *n, &st) <= 0)
        return -1;
    o->truth_a = st.l_avg;
    float *dark = malloc(sizeof *dark * (size_t)*n);
    if (!dark)
        return -1;
    for (long i = 0; i < *n; i++)
        dark[i] = (float)((*amps)[i] + b->dark_current_a);
    wdr_lum_stats_measure(dark, *n, &st);
    o->truth_dark_a = st.l_avg;
    free(dark);
    return 0;
}

static int save(const char *path, const uint8_t *bytes, size_t len)
{
    FILE *f = fopen(path, "wb");
    int ok = f && fwrite(bytes, 1, len, f) == len;
    if (f)
        ok = !fclose(f) && ok;
    return ok ? 0 : -1;
}

/* The operator of the LUT (WDR_EXPO_OP, default Reinhard). */
static const char *op_name(void)
{
    return env_or("WDR_EXPO_OP", "reinhard");
}

/* Calibrate the board through wdrctl (one host at a time), then connect again. */
static int calibrate(e2e_board *rig, const char *lut_path, const char *frames)
{
    char cal_path[160];
    snprintf(cal_path, sizeof cal_path, "%s/cal.bin", rig->dir);
    wdr_transport_close(rig->t);
    rig->t = NULL;
    /* --form compact: exposure does not depend on the table's form, and --form auto's judging of
     * up to four forms per board would add ~24 s here (test_cal_form_auto and e2e_main_job run it) */
    char *argv[] = {WDRCTL_PATH, "calibrate",    "--lut",    (char *)lut_path, "--upload", "-o",      cal_path,
                    "--frames",  (char *)frames, "--device", rig->address,     "--form",   (char *)env_or("WDR_EXPO_FORM", "compact"),
                    "--operator", (char *)op_name(), NULL};
    int rc = e2e_run(argv, 300);
    return rc == EX_OK && e2e_reconnect(rig) == 0 ? 0 : -1;
}

/* One scene on a fresh board: the key in force after each of FRAMES frames. */
static int run_scene(const char *board_name, const scene_def *d, unsigned long long seed, const char *cal_frames,
                     outcome *o)
{
    e2e_board rig;
    char dir[] = "/tmp/wdr-expo-XXXXXX", path[160], lut_path[160], err[256];
    if (!mkdtemp(dir))
        return -1;
    snprintf(path, sizeof path, "%s/%s.json", dir, d->name);
    snprintf(lut_path, sizeof lut_path, "%s/%s.lut", dir, op_name());
    float *amps = NULL;
    long n = 0;
    uint8_t *lut = NULL;
    size_t lut_len = 0;
    uint16_t *frame = NULL;
    int rc = -1;
    if (write_scene(path, d, seed) || e2e_start_scene(&rig, board_name, path, NULL))
        goto out;
    double key_a = 0.18 * rig.board.i_center_a; /* the key the default ramp is built for */
    if (scene_truth(path, &rig.board, o, &amps, &n) ||
        wdr_ramp_board_lut(&rig.board, op_name(), &lut, &lut_len, NULL, err, sizeof err) ||
        wdr_ramp_lut_append_exposure(&lut, &lut_len, &rig.board, key_a) || save(lut_path, lut, lut_len))
        goto stop;
    if (wdr_client_upload(rig.c, WDR_KIND_LUT, lut, lut_len, NULL, NULL, NULL) != WDR_OK)
        goto stop;
    if (cal_frames && calibrate(&rig, lut_path, cal_frames))
        goto stop;
    uint8_t on = 1;
    frame = calloc((size_t)n, sizeof *frame);
    if (!frame || wdr_client_request(rig.c, WDR_CMD_SET_EXPOSURE, &on, 1) != WDR_OK)
        goto stop;
    double key[FRAMES], settled = 0, estimate = 0;
    printf("%s scene, chip seed %llu: truth %.4g A (%.4g A with the dark current)\nframe | key in force A | error %% | "
           "tick ps | measured ln(L_avg / key) | integration ns\n",
           d->name, seed, o->truth_a, o->truth_dark_a);
    for (int k = 0; k < FRAMES; k++) {
        wdr_status_report st;
        if (wdr_client_capture(rig.c, 1, frame, NULL, NULL) != WDR_OK || wdr_client_status(rig.c, &st) != WDR_OK)
            goto stop;
        key[k] = key_a * exp(st.key_gain_q8 / 256.0);
        printf("%5d | %14.5g | %+7.2f | %u | %+.4f | %u\n", k + 1, key[k], 100 * (key[k] / o->truth_a - 1), st.tick_ps,
               st.last_error_q8 / 256.0, st.integration_ns);
        /* the frame was played at the key before this STATUS's update */
        double played = k ? key[k - 1] : key_a;
        if (k >= SETTLED_FROM) {
            settled += key[k] / (FRAMES - SETTLED_FROM);
            estimate += (st.last_error_q8 / 256.0 - log(o->truth_a / played)) / (FRAMES - SETTLED_FROM);
        }
        o->held = st.exposure_flags & (WDR_EXPO_HELD_DAC_RATE | WDR_EXPO_HELD_INTEGRATION);
    }
    o->estimate = estimate;
    const char *dump_dir = env_or("WDR_EXPO_DUMP", NULL);
    if (dump_dir) { /* the last frame's codes and the table, for a look by hand */
        char dump[256];
        snprintf(dump, sizeof dump, "%s/%s_%llu.u16", dump_dir, d->name, seed);
        save(dump, (const uint8_t *)frame, sizeof *frame * (size_t)n);
        snprintf(dump, sizeof dump, "%s/%s_%llu.lut", dump_dir, d->name, seed);
        save(dump, lut, lut_len); /* as built: the board plays it with calibrate's margin added */
        snprintf(dump, sizeof dump, "%s/%s_%llu.f32", dump_dir, d->name, seed);
        save(dump, (const uint8_t *)amps, sizeof *amps * (size_t)n);
        printf("dump: last key %.6g A\n", key[FRAMES - 1]);
    }
    o->settled_a = settled;
    o->error = settled / o->truth_a - 1;
    o->settle = FRAMES + 1;
    o->worst_late = 0;
    double tol = tolerance_of(d) > 0 ? tolerance_of(d) : TOLERANCE;
    for (int k = FRAMES - 1; k >= 0 && fabs(key[k] / o->truth_a - 1) < tol; k--)
        o->settle = k + 1;
    for (int k = SETTLED_FROM; k < FRAMES; k++)
        o->worst_late = fmax(o->worst_late, fabs(key[k] / o->truth_a - 1));
    double floor_a, ceiling_a;
    if (table_limits(lut, lut_len, key_a, &floor_a, &ceiling_a))
        goto stop;
    long below = 0, above = 0, dark = 0, bright = 0; /* at the settled exposure: the scene scaled by key / settled */
    for (long i = 0; i < n; i++) {
        double a = amps[i] * key_a / settled;
        below += a < rig.board.i_min_a, dark += a < floor_a;
        above += a > rig.board.i_max_a, bright += a > ceiling_a;
    }
    o->below = (double)below / (double)n, o->censored_dark = (double)dark / (double)n;
    o->above = (double)above / (double)n, o->censored_bright = (double)bright / (double)n;
    rc = 0;
stop:
    e2e_stop(&rig);
out:
    remove(path);
    remove(lut_path);
    rmdir(dir);
    free(amps);
    free(lut);
    free(frame);
    return rc;
}

/* WDR_EXPO_SCENES: a comma-separated list of scene names; unset runs them all but halves. */
static int scene_wanted(const scene_def *d)
{
    const char *list = getenv("WDR_EXPO_SCENES");
    size_t len = strlen(d->name);
    for (const char *p = list; p && *p; p += strcspn(p, ",") + (p[strcspn(p, ",")] != 0))
        if (strcspn(p, ",") == len && !strncmp(p, d->name, len))
            return 1;
    return !list && strcmp(d->name, "halves"); /* halves only when named: printed, and 35 s of CI */
}

int main(int argc, char **argv)
{
    const char *board_name = argc > 1 ? argv[1] : "sim-qvga";
    const char *cal_frames = getenv("WDR_EXPO_CAL_FRAMES");
    if (!cal_frames)
        cal_frames = "8";
    else if (!strcmp(cal_frames, "none"))
        cal_frames = NULL;
    int n_seeds = argc > 2 ? argc - 2 : 1, failed = 0;
    outcome all[16][N_SCENES];
    n_seeds = n_seeds > 16 ? 16 : n_seeds;
    for (int s = 0; s < n_seeds; s++) {
        unsigned long long seed = argc > 2 ? strtoull(argv[2 + s], NULL, 10) : 1;
        for (size_t i = 0; i < N_SCENES; i++) {
            if (!scene_wanted(&scenes[i])) {
                all[s][i].settle = -1;
                continue;
            }
            if (run_scene(board_name, &scenes[i], seed, cal_frames, &all[s][i]) != 0) {
                fprintf(stderr, "FAIL: %s scene, seed %llu: the board run did not complete\n", scenes[i].name, seed);
                return 1;
            }
        }
    }
    printf("\nauto exposure on %s, operator %s, every effect auto (noise, mismatch, dark current, droop, converters), "
           "%s\n",
           board_name, op_name(), cal_frames ? "calibrated on the board" : "uncalibrated");
    printf("scene  | seed | true log-average A | settled key A | error %% | worst of frames %d-%d %% | frames to "
           "settle | past i_min %% | past i_max %% | truth with dark current: error %% | held by | estimator ln | past the "
           "table's floor %% | past its ceiling %%\n",
           SETTLED_FROM + 1, FRAMES);
    for (int s = 0; s < n_seeds; s++)
        for (size_t i = 0; i < N_SCENES; i++) {
            const outcome *o = &all[s][i];
            if (o->settle < 0)
                continue; /* not run */
            unsigned long long seed = argc > 2 ? strtoull(argv[2 + s], NULL, 10) : 1;
            printf("%-6s | %4llu | %18.5g | %13.5g | %+7.2f | %22.2f | %16d | %11.1f | %11.1f | %+.2f | %s | %+.3f | "
                   "%.1f | %.1f\n",
                   scenes[i].name, seed, o->truth_a, o->settled_a, 100 * o->error, 100 * o->worst_late, o->settle,
                   100 * o->below, 100 * o->above, 100 * (o->settled_a / o->truth_dark_a - 1), held_name(o->held),
                   o->estimate, 100 * o->censored_dark, 100 * o->censored_bright);
            double tol = tolerance_of(&scenes[i]);
            if (tol > 0 && o->held) { /* past the board's limits: the key cannot reach it; the board must say
                                       * so, and know how far off it is */
                if (fabs(o->estimate) >= log1p(tol)) {
                    printf("FAIL: %s scene, seed %llu: held by the %s, its measured error is %+.3f ln off the "
                           "truth's (at most %.3f allowed)\n",
                           scenes[i].name, seed, held_name(o->held), o->estimate, log1p(tol));
                    failed = 1;
                }
            } else if (tol > 0 && (fabs(o->error) >= tol || o->worst_late >= tol || o->settle > SETTLE_MAX)) {
                printf("FAIL: %s scene, seed %llu: settled %+.2f %% from the log-average (worst late frame %.2f %%), "
                       "within %.1f %% from frame %d (at most %.1f %% from frame %d allowed)\n",
                       scenes[i].name, seed, 100 * o->error, 100 * o->worst_late, 100 * tol, o->settle, 100 * tol,
                       SETTLE_MAX);
                failed = 1;
            }
        }
    return failed;
}
