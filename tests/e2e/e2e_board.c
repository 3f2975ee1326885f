/* End-to-end rig (see e2e_board.h). */
#include "e2e_board.h"
#include "file_io.h"
#include "operators.h"
#include "pixel.h"
#include "wdr_err.h"
#include "wdr_lut.h"
#include "wdr_scene.h"
#include <cJSON.h>
#include <fcntl.h>
#include <math.h>
#include <signal.h>
#include <spawn.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#ifndef WDR_SIMBOARD_PATH
#error "WDR_SIMBOARD_PATH must name the wdr-simboard program"
#endif
#define START_DEADLINE_MS 15000
#define STOP_GRACE_MS 5000

extern char **environ;

/* ---- Scene ------------------------------------------------------------------------------------ */

/* The bundled default scene, with fixed pattern and noise off: what the software model knows. */
static int write_quiet_scene(const char *out)
{
    char *text = wdr_read_text(WDR_SOURCE_DIR "/sim/scenes/window.json");
    cJSON *root = text ? cJSON_Parse(text) : NULL;
    free(text);
    if (!root)
        return -1;
    static const char *const off[] = {"mismatch", "dark", "shot", "ktc", "read", "leakage"};
    static const char *const on[] = {"dac_quant", "adc_quant", "clipping"};
    cJSON *fx = cJSON_CreateObject();
    for (size_t i = 0; i < sizeof off / sizeof off[0]; i++)
        cJSON_AddStringToObject(fx, off[i], "off");
    for (size_t i = 0; i < sizeof on / sizeof on[0]; i++)
        cJSON_AddStringToObject(fx, on[i], "on");
    cJSON_ReplaceItemInObjectCaseSensitive(root, "effects", fx);
    cJSON_ReplaceItemInObjectCaseSensitive(root, "reference", cJSON_CreateTrue());
    char *json = cJSON_Print(root);
    cJSON_Delete(root);
    FILE *f = fopen(out, "w");
    int ok = f && json && fputs(json, f) >= 0;
    if (f)
        ok = !fclose(f) && ok;
    free(json);
    return ok ? 0 : -1;
}

/* ---- The child ---------------------------------------------------------------------------------- */

static int spawn_board(e2e_board *e, const char *board_path)
{
    int p[2];
    char log[160];
    if (pipe(p) != 0)
        return -1;
    snprintf(log, sizeof log, "%s/board.log", e->dir);
    posix_spawn_file_actions_t fa;
    posix_spawn_file_actions_init(&fa);
    posix_spawn_file_actions_adddup2(&fa, p[0], 0);
    posix_spawn_file_actions_addclose(&fa, p[1]);
    posix_spawn_file_actions_addopen(&fa, 2, log, O_WRONLY | O_CREAT | O_TRUNC, 0644);
    char *argv[12] = {WDR_SIMBOARD_PATH, "--board",  (char *)board_path, "--scene",
                      e->scene_path,     "--socket", e->socket_path};
    int n = 7;
    if (e->flash_path)
        argv[n++] = "--flash", argv[n++] = (char *)e->flash_path;
    if (e->firmware_path)
        argv[n++] = "--firmware", argv[n++] = (char *)e->firmware_path;
    argv[n] = NULL;
    int rc = posix_spawn(&e->pid, WDR_SIMBOARD_PATH, &fa, NULL, argv, environ);
    posix_spawn_file_actions_destroy(&fa);
    close(p[0]);
    e->stdin_fd = p[1];
    return rc == 0 ? 0 : -1;
}

static void print_log(const e2e_board *e)
{
    char path[160];
    snprintf(path, sizeof path, "%s/board.log", e->dir);
    char *text = wdr_read_text(path);
    fprintf(stderr, "wdr-simboard log:\n%s\n", text ? text : "(none)");
    free(text);
}

/* Connect once the board listens; give up if it exits or the deadline passes. */
static int connect_when_ready(e2e_board *e)
{
    char err[320] = "no attempt made";
    int64_t deadline = wdr_transport_now_ms() + START_DEADLINE_MS;
    while (wdr_transport_now_ms() < deadline) {
        if (wdr_transport_open(e->address, &e->t, err, sizeof err) == WDR_OK)
            return wdr_client_connect(e->c, e->t) == WDR_OK ? 0 : -1;
        int status;
        if (waitpid(e->pid, &status, WNOHANG) == e->pid) {
            e->pid = 0;
            return -1;
        }
        usleep(20000);
    }
    fprintf(stderr, "wdr-simboard did not listen within %d ms: %s\n", START_DEADLINE_MS, err);
    return -1;
}

int e2e_start(e2e_board *e, const char *board_name)
{
    return e2e_start_with_flash(e, board_name, NULL);
}

int e2e_start_with_flash(e2e_board *e, const char *board_name, const char *flash_path)
{
    return e2e_start_with_firmware(e, board_name, flash_path, NULL);
}

static int start_board(e2e_board *e, const char *board_name, const char *flash_path, const char *firmware_path,
                       const char *scene_json);

int e2e_start_with_firmware(e2e_board *e, const char *board_name, const char *flash_path, const char *firmware_path)
{
    return start_board(e, board_name, flash_path, firmware_path, NULL);
}

int e2e_start_scene(e2e_board *e, const char *board_name, const char *scene_json, const char *flash_path)
{
    return start_board(e, board_name, flash_path, NULL, scene_json);
}

static int copy_scene(const char *from, const char *to)
{
    char *text = wdr_read_text(from);
    FILE *f = text ? fopen(to, "w") : NULL;
    int ok = f && fputs(text, f) >= 0;
    if (f)
        ok = !fclose(f) && ok;
    free(text);
    return ok ? 0 : -1;
}

static int start_board(e2e_board *e, const char *board_name, const char *flash_path, const char *firmware_path,
                       const char *scene_json)
{
    char board_path[512], err[512];
    memset(e, 0, sizeof *e);
    e->flash_path = flash_path;
    e->firmware_path = firmware_path;
    e->stdin_fd = -1;
    snprintf(e->dir, sizeof e->dir, "/tmp/wdr-e2e-XXXXXX");
    if (!mkdtemp(e->dir))
        return -1;
    snprintf(e->socket_path, sizeof e->socket_path, "%s/board.sock", e->dir);
    snprintf(e->address, sizeof e->address, "sim:%s", e->socket_path);
    snprintf(e->scene_path, sizeof e->scene_path, "%s/scene.json", e->dir);
    wdr_board_path(board_name, board_path, sizeof board_path);
    wdr_board_defaults(&e->board); /* a board file overrides only what it names */
    if (wdr_board_load(board_path, &e->board, err, sizeof err) != WDR_OK) {
        fprintf(stderr, "%s\n", err);
        return -1;
    }
    e->c = calloc(1, sizeof *e->c);
    int scene = scene_json ? copy_scene(scene_json, e->scene_path) : write_quiet_scene(e->scene_path);
    if (!e->c || scene != 0 || spawn_board(e, board_path) != 0)
        return -1;
    e->c->timeout_ms = 5000;
    e->c->retries = WDR_CLIENT_RETRIES;
    if (connect_when_ready(e) != 0) {
        print_log(e);
        return -1;
    }
    return 0;
}

int e2e_reconnect(e2e_board *e)
{
    char err[320];
    wdr_transport_close(e->t);
    e->t = NULL;
    if (wdr_transport_open(e->address, &e->t, err, sizeof err) != WDR_OK) {
        fprintf(stderr, "%s\n", err);
        return -1;
    }
    return wdr_client_connect(e->c, e->t) == WDR_OK ? 0 : -1;
}

static int wait_child(pid_t pid, int ms)
{
    int status;
    for (int waited = 0; waited < ms; waited += 10) {
        if (waitpid(pid, &status, WNOHANG) == pid)
            return 0;
        usleep(10000);
    }
    return -1;
}

int e2e_wait_exit(e2e_board *e, int ms)
{
    int status;
    for (int waited = 0; waited <= ms; waited += 10) {
        if (waitpid(e->pid, &status, WNOHANG) == e->pid) {
            e->pid = 0;
            return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
        }
        usleep(10000);
    }
    return -1;
}

void e2e_stop(e2e_board *e)
{
    wdr_transport_close(e->t);
    free(e->c);
    if (e->stdin_fd >= 0)
        close(e->stdin_fd); /* EOF: the board ends by itself */
    if (e->pid > 0 && wait_child(e->pid, STOP_GRACE_MS) != 0) {
        kill(e->pid, SIGTERM);
        if (wait_child(e->pid, STOP_GRACE_MS) != 0) {
            kill(e->pid, SIGKILL);
            waitpid(e->pid, NULL, 0);
        }
    }
    char cmd[128];
    snprintf(cmd, sizeof cmd, "rm -rf %s", e->dir);
    if (e->dir[0] && system(cmd) != 0)
        fprintf(stderr, "could not remove %s\n", e->dir);
    memset(e, 0, sizeof *e);
}

int e2e_run(char *const argv[], int deadline_s)
{
    pid_t pid;
    if (posix_spawn(&pid, argv[0], NULL, NULL, argv, environ) != 0)
        return -1;
    int status;
    time_t t0 = time(NULL);
    while (waitpid(pid, &status, WNOHANG) == 0) {
        if (time(NULL) - t0 > deadline_s) {
            kill(pid, SIGKILL);
            waitpid(pid, &status, 0);
            return -1;
        }
        usleep(5000);
    }
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

/* ---- LUT and the software model ----------------------------------------------------------------- */

int e2e_reinhard_lut(const wdr_board *b, uint8_t **bytes, size_t *len)
{
    static wdr_operator op; /* large (user-curve knots): not on the stack */
    wdr_lum_stats st;
    wdr_ideal_pixel px;
    wdr_ramp ramp;
    char err[512];
    wdr_lum_stats_default(b->i_min_a, b->i_center_a, b->i_max_a, b->lum_per_amp, 0.18, &st);
    wdr_ideal_pixel_init(b, &px);
    int rc = wdr_operator_init(&op, "reinhard", &st, err, sizeof err);
    if (rc == WDR_OK)
        rc = wdr_ramp_build(&px, &op, b->i_min_a, b->i_max_a, 8192, WDR_RAMP_FAIL, &ramp, err, sizeof err);
    if (rc != WDR_OK) {
        fprintf(stderr, "%s\n", err);
        return rc;
    }
    rc = wdr_ramp_quantise(&ramp, b, &op, b->dac_timing, b->dac_uniform_entries, bytes, len, err, sizeof err);
    wdr_ramp_free(&ramp);
    if (rc != WDR_OK)
        fprintf(stderr, "%s\n", err);
    return rc;
}

/* The column ADC from the board file's own numbers: code = gain * full * v / span + offset. */
static uint16_t adc_code(const wdr_board *b, double v)
{
    double full = (double)((1u << b->adc_bits) - 1u), span = b->adc_hi_v - b->adc_lo_v;
    double code = floor(b->adc_gain * full * v / span + (b->adc_offset_v - b->adc_lo_v) * full / span + 0.5);
    return (uint16_t)(code < 0 ? 0 : code > full ? full : code);
}

uint16_t e2e_software_code(const wdr_board *b, const uint8_t *lut, size_t lut_len, double amps)
{
    wdr_lut_view view;
    wdr_ideal_pixel px;
    if (wdr_lut_parse(lut, lut_len, &view) != WDR_OK)
        return 0xffff;
    wdr_ideal_pixel_init(b, &px);
    return adc_code(b, wdr_pixel_sf_out(&px.dev, wdr_ramp_lut_ideal_response(&px, &view, amps)));
}

typedef struct soft_model {
    const wdr_board *b;
    wdr_ideal_pixel px;
    wdr_lut_view view;
    const float *amps;
    const long *order; /* pixel indices sorted by photocurrent */
    uint16_t *codes;
} soft_model;

static uint16_t soft_code(const soft_model *m, long pixel)
{
    return adc_code(m->b, wdr_pixel_sf_out(&m->px.dev, wdr_ramp_lut_ideal_response(&m->px, &m->view, m->amps[pixel])));
}

/* The response falls monotonically with light, so pixels between two sorted currents with the
 * same code share it: bisect the sorted range instead of evaluating all of it. */
static void fill_range(const soft_model *m, long lo, long hi, uint16_t c_lo, uint16_t c_hi)
{
    if (c_lo == c_hi) {
        for (long k = lo; k <= hi; k++)
            m->codes[m->order[k]] = c_lo;
        return;
    }
    m->codes[m->order[lo]] = c_lo;
    m->codes[m->order[hi]] = c_hi;
    if (hi - lo < 2)
        return;
    long mid = lo + (hi - lo) / 2;
    uint16_t c_mid = soft_code(m, m->order[mid]);
    fill_range(m, lo, mid, c_lo, c_mid);
    fill_range(m, mid, hi, c_mid, c_hi);
}

static const float *sort_amps;
static int by_current(const void *a, const void *b)
{
    float x = sort_amps[*(const long *)a], y = sort_amps[*(const long *)b];
    return (x > y) - (x < y);
}

int e2e_software_frame(const wdr_board *b, const char *scene_path, const uint8_t *lut, size_t lut_len, uint16_t *codes)
{
    wdr_scene sc;
    char err[512];
    soft_model m = {.b = b, .codes = codes};
    int rc = wdr_lut_parse(lut, lut_len, &m.view);
    if (rc == WDR_OK)
        rc = wdr_scene_load(scene_path, b, &sc, err, sizeof err);
    if (rc != WDR_OK)
        return rc;
    long n = (long)b->width * b->height;
    long *order = malloc((size_t)n * sizeof *order);
    if (!order) {
        wdr_scene_free(&sc);
        return WDR_E_NOMEM;
    }
    for (long i = 0; i < n; i++)
        order[i] = i;
    sort_amps = sc.amps;
    qsort(order, (size_t)n, sizeof *order, by_current);
    wdr_ideal_pixel_init(b, &m.px);
    m.amps = sc.amps;
    m.order = order;
    fill_range(&m, 0, n - 1, soft_code(&m, order[0]), soft_code(&m, order[n - 1]));
    free(order);
    wdr_scene_free(&sc);
    return WDR_OK;
}
