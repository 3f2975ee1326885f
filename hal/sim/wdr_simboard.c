/* wdr-simboard: the controller firmware running on the simulated HAL, its USB endpoints
 * served on a local socket for wdrctl (--device sim:PATH).
 *
 *   wdr-simboard --board FILE --scene FILE [--socket PATH] [--flash FILE] [--seed N] [--once]
 *
 * Ends cleanly on SIGTERM or SIGINT, when stdin is a pipe that reaches EOF (the parent went
 * away), or with --once when the first host disconnects. */
#include "board.h"
#include "hal.h"
#include "hal_sim_emul.h"
#include "simboard_loop.h"
#include "wdr_fw_config.h"
#include "wdr_err.h"
#include "wdr_scene.h"
#include "wdr_sim.h"
#include <errno.h>
#include <getopt.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sysexits.h>
#include <unistd.h>

typedef struct simboard_opts {
    const char *board, *scene, *socket, *flash;
    uint64_t seed;
    int seed_given, once;
} simboard_opts;

static void usage(FILE *f)
{
    fprintf(f, "usage: wdr-simboard --board FILE --scene FILE [--socket PATH] [--flash FILE] [--seed N] [--once]\n"
               "  --socket PATH  where wdrctl connects (default wdr-simboard.sock); wdrctl --device sim:PATH\n"
               "  --flash FILE   keep the table flash in FILE between runs (default: RAM, lost on exit)\n"
               "  --seed N       chip seed: fixed-pattern draw (default: the scene's chip_seed)\n"
               "  --once         exit when the first host disconnects\n");
}

static int parse_seed(const char *text, uint64_t *out)
{
    char *end;
    errno = 0;
    unsigned long long v = strtoull(text, &end, 0);
    if (errno || end == text || *end || text[0] == '-') {
        fprintf(stderr, "wdr-simboard: --seed must be a non-negative integer, got '%s'\n", text);
        return EX_USAGE;
    }
    *out = v;
    return EX_OK;
}

static int parse_args(int argc, char **argv, simboard_opts *o)
{
    static const struct option opts[] = {
        {"board", required_argument, NULL, 'b'}, {"scene", required_argument, NULL, 'S'},
        {"socket", required_argument, NULL, 's'}, {"flash", required_argument, NULL, 'f'},
        {"seed", required_argument, NULL, 'e'},  {"once", no_argument, NULL, 'o'},
        {"help", no_argument, NULL, 'h'},        {NULL, 0, NULL, 0}};
    *o = (simboard_opts){.socket = "wdr-simboard.sock", .seed = 1};
    int c;
    while ((c = getopt_long(argc, argv, "", opts, NULL)) != -1) {
        switch (c) {
        case 'b': o->board = optarg; break;
        case 'S': o->scene = optarg; break;
        case 's': o->socket = optarg; break;
        case 'f': o->flash = optarg; break;
        case 'o': o->once = 1; break;
        case 'e':
            if (parse_seed(optarg, &o->seed) != EX_OK)
                return EX_USAGE;
            o->seed_given = 1;
            break;
        case 'h': usage(stdout); exit(EX_OK);
        default: usage(stderr); return EX_USAGE;
        }
    }
    if (optind < argc || !o->board || !o->scene) {
        fprintf(stderr, "wdr-simboard: %s\n", optind < argc ? "unexpected argument" : "--board and --scene are required");
        usage(stderr);
        return EX_USAGE;
    }
    return EX_OK;
}

static void on_signal(int sig)
{
    (void)sig;
    hal_sim_request_stop();
}

static void install_signals(void)
{
    struct sigaction sa = {.sa_handler = on_signal}; /* no SA_RESTART: poll() returns at once */
    sigaction(SIGTERM, &sa, NULL);
    sigaction(SIGINT, &sa, NULL);
    signal(SIGPIPE, SIG_IGN);
}

static int exit_for(int rc) { return rc == WDR_E_IO ? EX_NOINPUT : rc == WDR_E_NOMEM ? EX_OSERR : EX_DATAERR; }

/* A --flash file that exists with bytes, but not this board's flash size: bad data (65), where
 * the other setup refusals are about how we were called (64). */
static int flash_file_wrong_size(const char *path)
{
    struct stat st;
    return path && stat(path, &st) == 0 && st.st_size != 0 &&
           (uint64_t)st.st_size != (uint64_t)HAL_SIM_FLASH_BLOCK_SIZE * HAL_SIM_FLASH_BLOCK_COUNT;
}

/* Board and scene files, then the board built from them; the scene lights the sensor and picks
 * its effects. --seed overrides the scene's chip seed. */
static int start_board(const simboard_opts *o, wdr_board *b)
{
    char err[512];
    wdr_scene scene;
    wdr_board_defaults(b); /* a board file overrides only what it names */
    int rc = wdr_board_load(o->board, b, err, sizeof err);
    if (rc == WDR_OK)
        rc = wdr_scene_load(o->scene, b, &scene, err, sizeof err);
    if (rc != WDR_OK) {
        fprintf(stderr, "wdr-simboard: %s\n", err);
        return exit_for(rc);
    }
    if (scene.warning[0])
        fprintf(stderr, "wdr-simboard: %s: %s\n", o->scene, scene.warning);
    hal_sim_config cfg = {.board = b, .seed = o->seed_given ? o->seed : scene.chip_seed,
                          .frame_seed = scene.frame_seed, .socket_path = o->socket, .flash_path = o->flash};
    rc = hal_sim_setup(&cfg, err, sizeof err);
    if (rc != WDR_OK) {
        fprintf(stderr, "wdr-simboard: %s\n", err);
        wdr_scene_free(&scene);
        return rc == WDR_E_IO ? EX_CANTCREAT : flash_file_wrong_size(o->flash) ? EX_DATAERR : EX_USAGE;
    }
    rc = wdr_scene_apply(&scene, hal_sim_sensor());
    if (rc != WDR_OK)
        fprintf(stderr, "wdr-simboard: scene %s does not fit board %s: %s\n", o->scene, o->board, wdr_strerror(rc));
    wdr_scene_free(&scene);
    return rc == WDR_OK ? EX_OK : EX_DATAERR;
}

/* A pipe on stdin ties our life to the parent's: its end closes, we end. */
static void watch_parent_pipe(void)
{
    struct stat st;
    if (fstat(0, &st) == 0 && S_ISFIFO(st.st_mode))
        hal_sim_watch_eof(0);
}

int main(int argc, char **argv)
{
    simboard_opts o;
    wdr_board b;
    int rc = parse_args(argc, argv, &o);
    if (rc != EX_OK)
        return rc;
    install_signals();
    if ((rc = start_board(&o, &b)) != EX_OK) {
        hal_sim_teardown();
        return rc;
    }
    if (b.width > WDR_FW_MAX_WIDTH) /* it serves INFO and STATUS; uploads and captures say UNSUPPORTED */
        fprintf(stderr, "wdr-simboard: warning: %s is %u pixels wide; the firmware reads at most %u pixels per row "
                "(WDR_FW_MAX_WIDTH): it will answer INFO and STATUS and refuse tables and captures\n", o.board,
                b.width, WDR_FW_MAX_WIDTH);
    hal_sim_set_exit_on_disconnect(o.once);
    watch_parent_pipe();
    fprintf(stderr, "wdr-simboard: %s %ux%u serving wdrctl --device sim:%s (SIGTERM or Ctrl-C stops)\n", b.name,
            b.width, b.height, o.socket);
    if (hal_init() != WDR_OK || (rc = simboard_serve()) != WDR_OK) {
        fprintf(stderr, "wdr-simboard: firmware did not start: %s\n", wdr_strerror(rc));
        hal_sim_teardown();
        return EX_SOFTWARE;
    }
    fprintf(stderr, "wdr-simboard: %s %ux%u stopped after %llu frames\n", b.name, b.width, b.height,
            (unsigned long long)hal_sim_frames_exposed());
    hal_sim_teardown();
    return EX_OK;
}
