/* wdr-simboard: the controller firmware running on the simulated HAL, its USB endpoints
 * served on a local socket for wdrctl (--device sim:PATH).
 *
 *   wdr-simboard --board FILE --scene FILE [--socket PATH] [--flash FILE] [--firmware IMG] [--seed N] [--once]
 *                [--light-by-hand FILE]
 *
 * Ends cleanly on SIGTERM or SIGINT, when stdin is a pipe that reaches EOF (the parent went
 * away), or with --once when the first host disconnects. */
#include "board.h"
#include "cli_options.h"
#include "hal.h"
#include "hal_sim_emul.h"
#include "simboard_loop.h"
#include "wdr_fw_config.h"
#include "wdr_err.h"
#include "wdr_scene.h"
#include "data_path.h"
#include "wdr_sim.h"
#include <errno.h>
#include <signal.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include "wdr_boot.h"
#include <sysexits.h>
#include <unistd.h>

typedef struct simboard_opts {
    const char *board, *scene, *socket, *flash, *firmware, *light_by_hand;
    uint64_t seed;
    int seed_given, once;
    const char *exposure_text;
    wdr_exposure exposure;       /* --exposure: how the scene is placed in the sensor's range */
} simboard_opts;

#define O(f) offsetof(simboard_opts, f)
static const cli_option rows[] = {
    {"board", 0, CLI_STRING, O(board), "NAME|FILE", "the board: a name (sim-vga) or a board.json file",
     .flags = CLI_REQUIRED, .values = "@boards"},
    {"scene", 0, CLI_STRING, O(scene), "NAME|FILE", "the scene the sensor looks at: a name (window) or a scene file",
     .flags = CLI_REQUIRED, .values = "@scenes"},
    {"socket", 0, CLI_STRING, O(socket), "PATH",
     "where wdrctl connects (default wdr-simboard.sock): wdrctl --device sim:PATH"},
    {"flash", 0, CLI_STRING, O(flash), "FILE",
     "keep the table flash in FILE and the image flash in FILE.images between runs (default: RAM, lost on exit)"},
    {"firmware", 0, CLI_STRING, O(firmware), "IMG",
     "a signed image (wdrctl fw sign) written into slot A when the image flash is blank, as a factory image"},
    {"seed", 0, CLI_U64, O(seed), "N", "chip seed: fixed-pattern draw (default: the scene's chip_seed)",
     .given = CLI_GIVEN(simboard_opts, seed_given)},
    {"once", 0, CLI_FLAG, O(once), NULL, "exit when the first host disconnects"},
    {"exposure", 0, CLI_STRING, O(exposure_text), "auto|A",
     "auto: the scene's log-average onto the ramp's key; or a scale in A per cd/m2"},
    {"light-by-hand", 0, CLI_STRING, O(light_by_hand), "FILE",
     "act as a real board: it cannot light itself (no illuminant in its INFO), and a person's lab light is "
     "read from FILE at each frame: a photocurrent in A per pixel, or 'scene' (missing: the scene)"},
    {0}};
#undef O

static const cli_command simboard_command = {
    NULL, NULL, 0, 0, "the controller firmware on the simulated HAL, served on a local socket", NULL, rows, NULL, 0};

static const cli_section sections[] = {
    {"ENVIRONMENT", "WDR_BOARDS_DIR: where board names are looked up (BOARDS_DIR/NAME/board.json; default: the installed share/wdrcam/boards).\n"
                    "WDR_SCENES_DIR: where scene names are looked up (SCENES_DIR/NAME.json; default: the installed share/wdrcam/scenes)."},
    {"EXAMPLES", "wdr-simboard --board sim-vga --scene window --socket /tmp/board.sock &"},
    {"SIGNALS", "SIGTERM or SIGINT ends it cleanly; so does the end of stdin when stdin is a pipe (the parent "
                "went away), and with --once the first host's disconnect."},
    {"EXIT STATUS", "0 on a clean stop; otherwise a sysexits(3) code: 64 usage, 65 a bad scene or board file, or "
                    "a --firmware image larger than slot A, 66 a file that cannot be read, 70 the firmware did not start, 73 the socket or flash file "
                    "cannot be created."},
    {"SEE ALSO", "wdrctl(1), wdrsim(1)"},
    {NULL, NULL}};

static void print_values(FILE *f, const char *kind) { wdr_data_print_names(f, kind); }

static const cli_program simboard_program = {
    .name = "wdr-simboard",
    .summary = "the wdrcam controller firmware on a simulated board",
    .description = "wdr-simboard runs the controller firmware on the simulated HAL: virtual time, strict flash, "
                   "the pixel-array simulator looking at a scene, and the USB bulk endpoints served on a local "
                   "socket for wdrctl --device sim:PATH.",
    .single = &simboard_command,
    .sections = sections,
    .print_values = print_values,
};

/* @return a sysexits code; *done when --help or --version was answered */
static int parse_args(int argc, char **argv, simboard_opts *o, int *done)
{
    int n_args;
    *o = (simboard_opts){.socket = "wdr-simboard.sock", .seed = 1};
    int rc = cli_main_single(&simboard_program, argc, argv, o, &n_args, done);
    if (rc == EX_OK && !*done && o->exposure_text && wdr_exposure_parse(o->exposure_text, &o->exposure)) {
        fprintf(stderr, "wdr-simboard: --exposure must be auto or A per cd/m2 in (0, 1], got '%s'\n", o->exposure_text);
        return EX_USAGE;
    }
    return rc;
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
    int rc = wdr_board_load_named(o->board, b, err, sizeof err);
    if (rc == WDR_OK)
        rc = wdr_scene_load_exposed(o->scene, b, &o->exposure, &scene, err, sizeof err);
    if (rc != WDR_OK) {
        fprintf(stderr, "wdr-simboard: %s\n", err);
        return exit_for(rc);
    }
    if (scene.warning[0])
        fprintf(stderr, "wdr-simboard: %s: %s\n", o->scene, scene.warning);
    wdr_scene_print_range(stderr, "wdr-simboard", &scene, b);
    char image_path[4096];
    if (o->flash)
        snprintf(image_path, sizeof image_path, "%s.images", o->flash);
    hal_sim_config cfg = {.board = b, .seed = o->seed_given ? o->seed : scene.chip_seed,
                          .frame_seed = scene.frame_seed, .socket_path = o->socket, .flash_path = o->flash,
                          .image_flash_path = o->flash ? image_path : NULL, .hand_light_path = o->light_by_hand};
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

/* --firmware IMG: flash a blank board's slot A, as a programmer would; a board that holds
 * images keeps them (the update path is wdrctl fw upload). */
static int flash_factory_image(const char *path)
{
    FILE *f = fopen(path, "rb");
    if (!f) {
        fprintf(stderr, "wdr-simboard: --firmware %s: %s\n", path, strerror(errno));
        return EX_NOINPUT;
    }
    static uint8_t image[HAL_SIM_IMAGE_BLOCK_SIZE * HAL_SIM_IMAGE_BLOCK_COUNT];
    size_t n = fread(image, 1, sizeof image, f);
    int too_long = fgetc(f) != EOF;
    fclose(f);
    if (!hal_sim_image_flash_blank()) {
        fprintf(stderr, "wdr-simboard: --firmware %s: the image flash already holds images; it keeps them\n", path);
        return EX_OK;
    }
    int rc = too_long ? WDR_E_TOO_LARGE : hal_sim_image_flash_write_factory(image, n);
    if (rc != WDR_OK) {
        const hal_flash_geometry g = {HAL_SIM_IMAGE_BLOCK_SIZE, HAL_SIM_IMAGE_BLOCK_COUNT, HAL_SIM_IMAGE_PROG_SIZE};
        wdr_boot_layout l = {0};
        wdr_boot_layout_init(&l, &g);
        fprintf(stderr, "wdr-simboard: --firmware %s: %zu%s bytes, slot A holds %u: %s\n", path, n, too_long ? "+" : "",
                l.image_capacity, wdr_strerror(rc));
        return EX_DATAERR;
    }
    fprintf(stderr, "wdr-simboard: --firmware %s: %zu bytes written into slot A (factory image)\n", path, n);
    return EX_OK;
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
    int done, rc = parse_args(argc, argv, &o, &done);
    if (rc != EX_OK || done)
        return rc;
    install_signals();
    if ((rc = start_board(&o, &b)) != EX_OK || (o.firmware && (rc = flash_factory_image(o.firmware)) != EX_OK)) {
        hal_sim_teardown();
        return rc;
    }
    if (b.width > WDR_FW_MAX_WIDTH) /* it serves INFO and STATUS; uploads and captures say UNSUPPORTED */
        fprintf(stderr, "wdr-simboard: warning: %s is %u pixels wide; the firmware reads at most %u pixels per row "
                "(WDR_FW_MAX_WIDTH): it will answer INFO and STATUS and refuse tables and captures\n", o.board,
                b.width, WDR_FW_MAX_WIDTH);
    hal_sim_set_exit_on_disconnect(o.once);
    watch_parent_pipe();
    hal_sim_set_boot_log(1);
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
