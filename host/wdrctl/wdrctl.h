/* wdrctl: the program's tables and helpers shared by the command files. Each command file
 * defines its commands (wdrctl_cmd_*: name, summary, option table, run function); main.c lists
 * them and holds the global options. */
#ifndef WDRCTL_H
#define WDRCTL_H
#include "cli_options.h"
#include <stddef.h>
#include <stdint.h>
#include <sysexits.h>

/* Global options: before or after any command that talks to a board (main.c). */
typedef struct wdrctl_globals {
    const char *device; /* --device ADDR, default $WDR_DEVICE */
    int timeout_ms;     /* --timeout MS per request */
    int retries;        /* --retries N of a request that timed out */
    int wait_ms;        /* --wait MS for a board that is starting */
} wdrctl_globals;
extern wdrctl_globals wdrctl_global;
extern const cli_program wdrctl_program;

/* Parse a command's argv by its table into opts (defaults set); positional arguments end up in
 * argv[1..*n_args]. @return a sysexits code, the problem printed */
int wdrctl_parse(const cli_command *cmd, int argc, char **argv, void *opts, int *n_args);

/* The commands, in the order of `wdrctl --help`. */
extern const cli_command wdrctl_cmd_operators, wdrctl_cmd_lut_build, wdrctl_cmd_lut_plots, wdrctl_cmd_tonemap;
extern const cli_command wdrctl_cmd_devices, wdrctl_cmd_info, wdrctl_cmd_status, wdrctl_cmd_lut_upload,
    wdrctl_cmd_lut_select, wdrctl_cmd_cal_upload, wdrctl_cmd_integration, wdrctl_cmd_exposure, wdrctl_cmd_capture, wdrctl_cmd_stream,
    wdrctl_cmd_sim_illuminant;
extern const cli_command wdrctl_cmd_calibrate, wdrctl_cmd_fpn_report, wdrctl_cmd_study;
extern const cli_command wdrctl_cmd_fw_sign, wdrctl_cmd_fw_info, wdrctl_cmd_fw_upload, wdrctl_cmd_fw_status,
    wdrctl_cmd_fw_confirm, wdrctl_cmd_fw_revert, wdrctl_cmd_reboot;

/* Commands, one per file group (cmd_*.c). */
int cmd_operators(int argc, char **argv);
int cmd_lut_build(int argc, char **argv);
int cmd_lut_plots(int argc, char **argv);
int cmd_tonemap(int argc, char **argv);
int cmd_devices(int argc, char **argv);
int cmd_info(int argc, char **argv);
int cmd_status(int argc, char **argv);
int cmd_lut_upload(int argc, char **argv);
int cmd_lut_select(int argc, char **argv);
int cmd_cal_upload(int argc, char **argv);
int cmd_integration(int argc, char **argv);
int cmd_exposure(int argc, char **argv);
int cmd_capture(int argc, char **argv);
int cmd_stream(int argc, char **argv);
int cmd_sim_illuminant(int argc, char **argv);

/* Calibration (cmd_calibrate.c, cmd_fpn_report.c). */
int cmd_calibrate(int argc, char **argv);
int cmd_fpn_report(int argc, char **argv);

/* What accuracy costs (cmd_study.c over host/study/). */
int cmd_study(int argc, char **argv);

/* Firmware images: files (cmd_fw_image.c) and boards (cmd_fw.c). */
int cmd_fw_sign(int argc, char **argv);
int cmd_fw_info(int argc, char **argv);
int cmd_fw_upload(int argc, char **argv);
int cmd_fw_status(int argc, char **argv);
int cmd_fw_confirm(int argc, char **argv);
int cmd_fw_revert(int argc, char **argv);
int cmd_reboot(int argc, char **argv);

/* Scene statistics of an HDR image (wdr_lum_stats in operators.h); a sysexits code. The image
 * goes through the one pixel policy (wdr_hdr_sanitize): NaN/Inf refused, negatives clamped. */
struct wdr_lum_stats;
int wdrctl_stats_from_image(const char *path, struct wdr_lum_stats *st);

/* Scene statistics as the sensor sees the scene: its photocurrent map (fitted, exposed) times
 * the board's lum_per_A, the luminance every operator and the software tone map work in. */
struct wdr_scene;
struct wdr_board;
int wdrctl_stats_from_scene(const struct wdr_scene *sc, const struct wdr_board *b, struct wdr_lum_stats *st);

/* Print "wdrctl: " and a formatted message to stderr; returns code. A macro so that the
 * static analysers see the code come back (a function in another file hides it). */
void wdrctl_message(const char *fmt, ...) __attribute__((format(printf, 1, 2)));
#define wdrctl_fail(code, ...) (wdrctl_message(__VA_ARGS__), (code))

/* Whether progress may be drawn (stderr is a terminal and CI is not set). */
int wdrctl_show_progress(void);

/* A connection to a board (cmd_device.c), for every command that talks to one. */
typedef struct wdrctl_conn {
    struct wdr_transport *t;
    struct wdr_client *c; /* protocol client; c->info holds the board's INFO */
} wdrctl_conn;

/* Open address (sim:/path.sock, usb, usb:BUS-ADDR; NULL: none given) and check the protocol
 * version. Prints the reason on failure. @return a sysexits code (EX_OK when connected) */
/* The output-name rule (image_io.h's wdr_output_name_check) for cmd's option: EX_OK, or EX_USAGE
 * with the message. NULL path: nothing to check. */
int wdrctl_check_output(const char *cmd, const char *path, const char *exts);

int wdrctl_connect(const char *address, int timeout_ms, int retries, wdrctl_conn *conn);
/* The same, looking again every 50 ms for wait_ms for a board that is absent (starting). */
int wdrctl_connect_wait(const char *address, int timeout_ms, int retries, int wait_ms, wdrctl_conn *conn);
void wdrctl_disconnect(wdrctl_conn *conn);

/* After an upload whose COMMIT lost the link (c->commit_unknown): disconnect, connect again
 * (waiting up to 3 s), and ask STATUS whether this table is active. Prints the outcome.
 * @return EX_OK (it is active), EX_IOERR (the previous table is), EX_TEMPFAIL (no answer) */
int wdrctl_commit_outcome(wdrctl_conn *conn, const char *address, int kind, const uint8_t *table, size_t len);

/* Print the client's last error and return its sysexits code (rc: what the client returned). */
int wdrctl_conn_fail(wdrctl_conn *conn, int rc);

/* sysexits code for a transport/client result and, for WDR_E_STATUS, the board's status:
 * absent EX_UNAVAILABLE, no permission EX_NOPERM, timeout EX_TEMPFAIL, disconnect EX_IOERR,
 * protocol trouble EX_PROTOCOL, refused data EX_DATAERR, no LUT on the board EX_CONFIG. */
int wdrctl_exit_code(int rc, int status);

#endif
