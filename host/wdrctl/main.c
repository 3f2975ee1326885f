/* wdrctl: the host tool. The commands' tables (each in its cmd_*.c) and the global options;
 * host/lib/cli_options.c does the parsing, help, man page and completion from them. */
#include "image_io.h"
#include "transport_client.h"
#include "value_lists.h"
#include "wdrctl.h"
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

wdrctl_globals wdrctl_global;

#define G(f) offsetof(wdrctl_globals, f)
static const cli_option global_rows[] = {
    {"device", 0, CLI_STRING, G(device), "ADDR",
     "the board: sim:/path.sock, usb, usb:BUS-ADDR, serial:/dev/ttyACM0[@BAUD], unix:PATH or tcp:HOST:PORT "
     "(default: $WDR_DEVICE)", .values = "@devices"},
    {"timeout", 0, CLI_INT, G(timeout_ms), "MS", "reply timeout per request attempt, per connect, and a frame's allowance past the board's frame time (default 2000)", .min = 1,
     .max = 3600000},
    {"retries", 0, CLI_INT, G(retries), "N", "extra attempts after a timeout or a garbled reply (default 2)", .min = 0,
     .max = 100},
    {"wait", 0, CLI_INT, G(wait_ms), "MS", "keep looking this long for a board that is starting (default 0)",
     .min = 0, .max = 3600000},
    {0}};
#undef G

static const cli_command *const commands[] = {
    &wdrctl_cmd_operators, &wdrctl_cmd_lut_build, &wdrctl_cmd_lut_plots, &wdrctl_cmd_lut_upload,
    &wdrctl_cmd_lut_select, &wdrctl_cmd_tonemap, &wdrctl_cmd_devices, &wdrctl_cmd_info, &wdrctl_cmd_status,
    &wdrctl_cmd_cal_upload, &wdrctl_cmd_integration, &wdrctl_cmd_exposure, &wdrctl_cmd_capture, &wdrctl_cmd_stream,
    &wdrctl_cmd_sim_illuminant, &wdrctl_cmd_calibrate, &wdrctl_cmd_fpn_report, &wdrctl_cmd_study,
    &wdrctl_cmd_fw_sign, &wdrctl_cmd_fw_info, &wdrctl_cmd_fw_upload, &wdrctl_cmd_fw_status, &wdrctl_cmd_fw_confirm,
    &wdrctl_cmd_fw_revert, &wdrctl_cmd_reboot, NULL};

static const cli_section sections[] = {
    {"ENVIRONMENT", "WDR_DEVICE: the board when --device is not given.\n"
                    "WDR_BOARDS_DIR: where board names are looked up (BOARDS_DIR/NAME/board.json; default: the installed share/wdrcam/boards).\n"
                    "WDR_SCENES_DIR: where scene names are looked up (SCENES_DIR/NAME.json; default: the installed share/wdrcam/scenes).\n"
                    "CI: when set (and not 'false'), no progress is drawn on a terminal."},
    {"EXIT STATUS", "0 on success; otherwise a sysexits(3) code: 64 usage (a bad option or value), 65 bad data, "
                    "66 an input that cannot be read, 69 no board, 70 internal error, 71 out of memory, 73 an "
                    "output that cannot be created, 74 I/O error, 75 timeout or busy board, 76 protocol error, "
                    "77 no permission, 78 bad configuration (a board file, no LUT on the board)."},
    {"EXAMPLES", "wdrctl operators\n"
                 "wdrctl lut build --operator drago --param bias=0.85 -o drago.lut --csv drago.csv --plot drago.png --json\n"
                 "wdrctl lut plots --outdir plots/\n"
                 "wdrctl --device sim:/tmp/board.sock info\n"
                 "wdrctl lut upload drago.lut\n"
                 "wdrctl calibrate --lut drago.lut --upload -o cal.bin --json\n"
                 "wdrctl sim illuminant scene\n"
                 "wdrctl capture -n 4 -o frame.png --negate\n"
                 "wdrctl fpn report --outdir fpn/\n"
                 "wdrctl tonemap --scene window -o soft.png --capture frame.pfm --side-by-side sbs.png"},
    {"SEE ALSO", "wdrsim(1), wdr-simboard(1), wdr-hdrgen(1), wdr-board(1)"},
    {NULL, NULL}};

const cli_program wdrctl_program = {
    .name = "wdrctl",
    .summary = "build ramp tables, calibrate and drive wdrcam tone-mapping image sensor boards",
    .description = "wdrctl builds the DAC ramp table (LUT) of a tone-mapping operator, calibrates the sensor's "
                   "fixed-pattern noise, uploads tables to a board, captures and streams frames, and reports. "
                   "A board is a real one over USB or a simulated one (wdr-simboard) over a local socket.",
    .globals = global_rows,
    .globals_size = sizeof(wdrctl_globals),
    .commands = commands,
    .sections = sections,
    .print_values = wdr_print_values,
};

int wdrctl_parse(const cli_command *cmd, int argc, char **argv, void *opts, int *n_args)
{
    return cli_parse(&wdrctl_program, cmd, argc, argv, opts, n_args);
}

void wdrctl_message(const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    fputs("wdrctl: ", stderr);
    vfprintf(stderr, fmt, ap);
    fputc('\n', stderr);
    va_end(ap);
}

int wdrctl_check_output(const char *cmd, const char *path, const char *exts)
{
    char err[300];
    if (path && wdr_output_name_check(path, exts, err, sizeof err))
        return wdrctl_fail(EX_USAGE, "%s: %s", cmd, err);
    return EX_OK;
}

int wdrctl_show_progress(void)
{
    const char *ci = getenv("CI");
    return isatty(2) && !(ci && *ci && strcmp(ci, "false"));
}

int main(int argc, char **argv)
{
    wdrctl_global = (wdrctl_globals){.device = getenv("WDR_DEVICE"), .timeout_ms = WDR_CLIENT_TIMEOUT_MS,
                                     .retries = WDR_CLIENT_RETRIES};
    return cli_main(&wdrctl_program, argc, argv, &wdrctl_global);
}
