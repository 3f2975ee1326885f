/* wdrctl: command table and helpers shared by the command files. */
#ifndef WDRCTL_H
#define WDRCTL_H
#include <sysexits.h>

typedef struct wdrctl_command {
    const char *group;   /* e.g. "lut", or NULL for a top-level command */
    const char *name;    /* e.g. "build" */
    int (*run)(int argc, char **argv); /* argv[0] is the command name; returns a sysexits code */
    const char *usage;
} wdrctl_command;

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
int cmd_capture(int argc, char **argv);
int cmd_stream(int argc, char **argv);
int cmd_sim_illuminant(int argc, char **argv);

/* Calibration (cmd_cal.c). */
int cmd_calibrate(int argc, char **argv);
int cmd_fpn_report(int argc, char **argv);

/* What accuracy costs (cmd_study.c over host/study/). */
int cmd_study(int argc, char **argv);

/* Scene statistics of an HDR image (wdr_lum_stats in operators.h); a sysexits code. */
struct wdr_lum_stats;
int wdrctl_stats_from_image(const char *path, struct wdr_lum_stats *st);

/* Print "wdrctl: " and a formatted message to stderr; returns code. */
int wdrctl_fail(int code, const char *fmt, ...) __attribute__((format(printf, 2, 3)));

/* Whether progress may be drawn (stderr is a terminal and CI is not set). */
int wdrctl_show_progress(void);

/* A connection to a board (cmd_device.c), for every command that talks to one. */
typedef struct wdrctl_conn {
    struct wdr_transport *t;
    struct wdr_client *c; /* protocol client; c->info holds the board's INFO */
} wdrctl_conn;

/* Open address (sim:/path.sock, usb, usb:BUS-ADDR; NULL: none given) and check the protocol
 * version. Prints the reason on failure. @return a sysexits code (EX_OK when connected) */
int wdrctl_connect(const char *address, int timeout_ms, int retries, wdrctl_conn *conn);
void wdrctl_disconnect(wdrctl_conn *conn);

/* Print the client's last error and return its sysexits code (rc: what the client returned). */
int wdrctl_conn_fail(wdrctl_conn *conn, int rc);

/* sysexits code for a transport/client result and, for WDR_E_STATUS, the board's status:
 * absent EX_UNAVAILABLE, no permission EX_NOPERM, timeout EX_TEMPFAIL, disconnect EX_IOERR,
 * protocol trouble EX_PROTOCOL, refused data EX_DATAERR, no LUT on the board EX_CONFIG. */
int wdrctl_exit_code(int rc, int status);

#endif
