/* wdrctl commands that talk to a board: devices, info, status, lut upload/select, cal upload,
 * capture, stream, integration, sim illuminant. The board is chosen with --device ADDR or
 * $WDR_DEVICE (sim:/path.sock, usb, usb:BUS-ADDR); failures map to sysexits codes. */
#include "cli_number.h"
#include "crc32.h"
#include "file_io.h"
#include "fw_sign.h"
#include "image_io.h"
#include "transport.h"
#include "transport_client.h"
#include "v4l2_out.h"
#include "wdr_cal.h"
#include "wdr_err.h"
#include "wdr_fw_config.h"
#include "wdr_lut.h"
#include "wdrctl.h"
#include <cJSON.h>
#include <errno.h>
#include <math.h>
#include <signal.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <unistd.h>

/* ---- Options: one table per command, from rows shared by the device commands ------------------ */

typedef struct dev_opts {
    const char *device, *out, *v4l2;
    int timeout_ms, retries, wait_ms, count, bits, raw, average, no_verify, negate, json, v4l2_format;
    double seconds, fps;
    int n_args;
    char **args; /* positional arguments after the options */
} dev_opts;

#define O(f) offsetof(dev_opts, f)
#define ROW_JSON {"json", 0, CLI_FLAG, O(json), NULL, "print JSON"}
#define ROW_NO_VERIFY {"no-verify", 0, CLI_FLAG, O(no_verify), NULL, "skip the check of the file against the board"}
#define ROW_COUNT(what) {"count", 'n', CLI_INT, O(count), "N", what, .min = 1, .max = 65535}
static const cli_choice bit_depths[] = {{"8", 8}, {"16", 16}, {NULL, 0}};
static const cli_option no_rows[] = {{0}};
static const cli_option json_rows[] = {ROW_JSON, {0}};
static const cli_option upload_rows[] = {ROW_NO_VERIFY, {0}};
static const cli_option capture_rows[] = {
    {"output", 'o', CLI_STRING, O(out), "FILE", "FILE.png or FILE.pfm (raw codes); numbered for several frames",
     .flags = CLI_REQUIRED},
    ROW_COUNT("frames to capture (default 1)"),
    {"bits", 0, CLI_CHOICE, O(bits), NULL, "PNG depth (default 16)", .choices = bit_depths, .what = "PNG depth"},
    {"raw", 0, CLI_FLAG, O(raw), NULL, "PNG of the codes as they are (16-bit), not scaled to the depth"},
    {"average", 0, CLI_FLAG, O(average), NULL, "one image, the mean of the N frames"},
    {"negate", 0, CLI_FLAG, O(negate), NULL, "brighter light looks brighter (the codes fall with light)"},
    {0}};
static const cli_choice v4l2_formats[] = {{"grey", WDR_V4L2_GREY}, {"y16", WDR_V4L2_Y16}, {NULL, 0}};
static const cli_option stream_rows[] = {
    ROW_COUNT("stop after N frames (default: Ctrl-C)"),
    {"seconds", 0, CLI_DOUBLE, O(seconds), "S", "stop after S seconds", .min = 0, .max = 1e9},
    {"v4l2", 0, CLI_STRING, O(v4l2), "DEV",
     "feed a V4L2 output device (v4l2loopback: /dev/videoN), or a file or pipe with the raw frames"},
    {"format", 0, CLI_CHOICE, O(v4l2_format), NULL,
     "with --v4l2: grey (8-bit display image, default) or y16 (16-bit corrected codes)", .choices = v4l2_formats,
     .what = "V4L2 format"},
    {"fps", 0, CLI_DOUBLE, O(fps), "F", "with --v4l2: frames per second announced (default: the board's frame time)",
     .min = 0.001, .max = 1000},
    {0}};
#undef O

#define DEVICE_COMMAND(var, name, args, lo, hi, summary, rows, fn) \
    int fn(int argc, char **argv);                                \
    const cli_command var = {name, args, lo, hi, summary, NULL, rows, fn, CLI_CMD_BOARD}
DEVICE_COMMAND(wdrctl_cmd_devices, "devices", NULL, 0, 0,
               "list wdrcam USB boards, and the simulated one given by --device", no_rows, cmd_devices);
DEVICE_COMMAND(wdrctl_cmd_info, "info", NULL, 0, 0, "board identity and protocol version", json_rows, cmd_info);
DEVICE_COMMAND(wdrctl_cmd_status, "status", NULL, 0, 0, "state, active tables, counters", json_rows, cmd_status);
DEVICE_COMMAND(wdrctl_cmd_lut_upload, "lut upload", "LUT.bin", 1, 1, "store a LUT in flash and play it", upload_rows,
               cmd_lut_upload);
DEVICE_COMMAND(wdrctl_cmd_lut_select, "lut select", "A|B|newest", 1, 1, "play the LUT of a slot", no_rows,
               cmd_lut_select);
DEVICE_COMMAND(wdrctl_cmd_cal_upload, "cal upload", "CAL.bin", 1, 1,
               "store a calibration table in flash and apply it", upload_rows, cmd_cal_upload);
DEVICE_COMMAND(wdrctl_cmd_integration, "integration", "NS", 1, 1, "set the integration time (0: the LUT's own)",
               no_rows, cmd_integration);
DEVICE_COMMAND(wdrctl_cmd_exposure, "exposure", "auto|fixed", 1, 1,
               "the board retimes its ramp to the scene (LUT 1.1 exposure table), or stops", no_rows, cmd_exposure);
DEVICE_COMMAND(wdrctl_cmd_capture, "capture", NULL, 0, 0, "capture N frames to PNG or PFM files", capture_rows,
               cmd_capture);
DEVICE_COMMAND(wdrctl_cmd_stream, "stream", NULL, 0, 0, "frames back to back, one line each, until Ctrl-C",
               stream_rows, cmd_stream);
DEVICE_COMMAND(wdrctl_cmd_sim_illuminant, "sim illuminant", "AMPS|scene", 1, 1,
               "light every pixel of a simulated board uniformly, or put its scene back", no_rows,
               cmd_sim_illuminant);

/* Parse argv (argv[0] is the command name) by cmd's table; the board from the global options. */
static int parse_opts(int argc, char **argv, const cli_command *cmd, dev_opts *o)
{
    memset(o, 0, sizeof *o);
    o->device = wdrctl_global.device;
    o->timeout_ms = wdrctl_global.timeout_ms;
    o->retries = wdrctl_global.retries;
    o->wait_ms = wdrctl_global.wait_ms;
    o->bits = 16;
    int rc = wdrctl_parse(cmd, argc, argv, o, &o->n_args);
    o->args = argv + 1;
    return rc;
}

/* A positional number (NS, AMPS) in lo..hi, by the one number parser. */
static int parse_arg(const char *cmd, const char *name, const char *text, double lo, double hi, double *out)
{
    char msg[320], what[64];
    int rc = cli_number_double(text, lo, hi, out);
    if (rc == CLI_NUM_OK)
        return EX_OK;
    snprintf(what, sizeof what, "%s: %s", cmd, name);
    cli_number_message(rc, what, text, lo, hi, 0, msg, sizeof msg);
    return wdrctl_fail(EX_USAGE, "%s", msg);
}

/* ---- Connection and exit codes --------------------------------------------------------------- */

static int exit_for_status(int status)
{
    switch (status) {
    case WDR_ST_BUSY: return EX_TEMPFAIL;
    case WDR_ST_NO_TABLE: return EX_CONFIG;
    case WDR_ST_UNSUPPORTED: return EX_UNAVAILABLE;
    case WDR_ST_BAD_SEQUENCE:
    case WDR_ST_BAD_LENGTH:
    case WDR_ST_BAD_VERSION: return EX_PROTOCOL;
    case WDR_ST_FLASH: return EX_IOERR;
    default: return EX_DATAERR; /* the table or value we sent was refused */
    }
}

int wdrctl_exit_code(int rc, int status)
{
    switch (rc) {
    case WDR_OK: return EX_OK;
    case WDR_E_ABSENT: return EX_UNAVAILABLE;
    case WDR_E_DENIED: return EX_NOPERM;
    case WDR_E_BUSY:
    case WDR_E_TIMEOUT: return EX_TEMPFAIL;
    case WDR_E_IO:
    case WDR_E_FRAME: return EX_IOERR;
    case WDR_E_PROTOCOL:
    case WDR_E_VERSION:
    case WDR_E_CORRUPT: return EX_PROTOCOL;
    case WDR_E_INVAL: return EX_USAGE;
    case WDR_E_UNSUPPORTED: return EX_UNAVAILABLE; /* the board cannot do it (an older protocol) */
    case WDR_E_NOMEM: return EX_OSERR;
    case WDR_E_STATUS: return exit_for_status(status);
    default: return EX_SOFTWARE;
    }
}

/* Open address; a board that is absent is looked for again every 50 ms for wait_ms (one that
 * is starting: its socket not there yet, or not yet enumerated). A connection not accepted
 * within timeout_ms fails (a listener whose queue is full). */
static int open_waiting(const char *address, int timeout_ms, int wait_ms, wdr_transport **t, char *err, int errlen)
{
    int64_t deadline = wdr_transport_now_ms() + wait_ms;
    for (;;) {
        int rc = wdr_transport_open_within(address, timeout_ms, t, err, errlen);
        if (rc != WDR_E_ABSENT || wdr_transport_now_ms() >= deadline)
            return rc;
        usleep(50000);
    }
}

static int connect_waiting(const char *address, int timeout_ms, int retries, int wait_ms, wdrctl_conn *conn)
{
    char err[320];
    memset(conn, 0, sizeof *conn);
    int rc = open_waiting(address, timeout_ms, wait_ms, &conn->t, err, sizeof err);
    if (rc != WDR_OK)
        return wdrctl_fail(wdrctl_exit_code(rc, 0), "%s", err);
    conn->c = calloc(1, sizeof *conn->c);
    if (!conn->c) {
        wdr_transport_close(conn->t);
        return wdrctl_fail(EX_OSERR, "out of memory");
    }
    conn->c->timeout_ms = timeout_ms;
    conn->c->retries = retries;
    rc = wdr_client_connect(conn->c, conn->t);
    if (rc != WDR_OK) {
        int code = wdrctl_conn_fail(conn, rc);
        wdrctl_disconnect(conn);
        return code != EX_OK ? code : EX_SOFTWARE; /* a failed connect never reads as a connection */
    }
    return EX_OK;
}

int wdrctl_connect(const char *address, int timeout_ms, int retries, wdrctl_conn *conn)
{
    return connect_waiting(address, timeout_ms, retries, 0, conn);
}

int wdrctl_connect_wait(const char *address, int timeout_ms, int retries, int wait_ms, wdrctl_conn *conn)
{
    return connect_waiting(address, timeout_ms, retries, wait_ms, conn);
}

int wdrctl_conn_fail(wdrctl_conn *conn, int rc)
{
    const wdr_info *i = &conn->c->info;
    int refused = rc == WDR_E_STATUS && (conn->c->status == WDR_ST_UNSUPPORTED || conn->c->status == WDR_ST_NO_TABLE);
    if (refused && i->width > WDR_FW_MAX_WIDTH) /* the likely reason, which the status alone does not give */
        return wdrctl_fail(wdrctl_exit_code(rc, conn->c->status),
                           "%s (the board's sensor is %u pixels wide; this firmware handles at most %u per row)",
                           conn->c->err, i->width, WDR_FW_MAX_WIDTH);
    return wdrctl_fail(wdrctl_exit_code(rc, conn->c->status), "%s", conn->c->err);
}

void wdrctl_disconnect(wdrctl_conn *conn)
{
    wdr_transport_close(conn->t);
    free(conn->c);
    memset(conn, 0, sizeof *conn);
}

static int connect_opts(const dev_opts *o, wdrctl_conn *conn)
{
    return connect_waiting(o->device, o->timeout_ms, o->retries, o->wait_ms, conn);
}

/* ---- devices, info, status ----------------------------------------------------------------------- */

static void print_sim_device(const dev_opts *o)
{
    wdrctl_conn conn;
    if (wdrctl_connect(o->device, o->timeout_ms, o->retries, &conn) != EX_OK)
        return; /* the message is out; listing goes on */
    const wdr_info *i = &conn.c->info;
    printf("%-24s simulated  %-16s %ux%u  sensor 0x%08x\n", o->device, i->name, i->width, i->height, i->sensor_id);
    wdrctl_disconnect(&conn);
}

int cmd_devices(int argc, char **argv)
{
    dev_opts o;
    int rc = parse_opts(argc, argv, &wdrctl_cmd_devices, &o);
    if (rc != EX_OK)
        return rc;
    wdr_usb_board boards[16];
    char err[256];
    int n = wdr_transport_list_usb(boards, 16, err, sizeof err);
    if (n < 0)
        wdrctl_message("USB: %s", err);
    for (int i = 0; i < n; i++)
        printf("%-24s usb        %04x:%04x        serial %s\n", boards[i].address_text, boards[i].vid, boards[i].pid,
               boards[i].serial);
    if (o.device && !strncmp(o.device, "sim:", 4))
        print_sim_device(&o);
    else if (n <= 0)
        fprintf(stderr, "wdrctl: no wdrcam USB board (%04x:%04x) found; give --device sim:PATH for a simulated one\n",
                WDR_USB_VID, WDR_USB_PID);
    return EX_OK;
}

static void print_info_json(const char *device, const wdr_info *i)
{
    cJSON *o = cJSON_CreateObject();
    cJSON_AddStringToObject(o, "device", device);
    cJSON_AddStringToObject(o, "board", i->name);
    cJSON_AddNumberToObject(o, "sensor_id", i->sensor_id);
    cJSON_AddNumberToObject(o, "width", i->width);
    cJSON_AddNumberToObject(o, "height", i->height);
    cJSON_AddNumberToObject(o, "adc_bits", i->adc_bits);
    cJSON_AddNumberToObject(o, "dac_bits", i->dac_bits);
    cJSON_AddNumberToObject(o, "row_time_ns", i->row_time_ns);
    cJSON_AddNumberToObject(o, "protocol_major", i->proto_major);
    cJSON_AddNumberToObject(o, "protocol_minor", i->proto_minor);
    cJSON_AddNumberToObject(o, "firmware_major", i->fw_major);
    cJSON_AddNumberToObject(o, "firmware_minor", i->fw_minor);
    cJSON_AddNumberToObject(o, "firmware_patch", i->fw_patch);
    cJSON_AddNumberToObject(o, "firmware_build", i->fw_build);
    cJSON_AddStringToObject(o, "image_slot", i->fw_slot == 0 ? "A" : i->fw_slot == 1 ? "B" : "none");
    cJSON_AddBoolToObject(o, "test_boot", (i->fw_flags & 1) != 0);
    cJSON_AddNumberToObject(o, "max_payload", i->max_payload);
    cJSON_AddNumberToObject(o, "lut_capacity", i->lut_capacity);
    cJSON_AddNumberToObject(o, "cal_capacity", i->cal_capacity);
    cJSON_AddBoolToObject(o, "simulated", (i->caps & WDR_INFO_CAP_ILLUMINANT) != 0);
    char *text = cJSON_Print(o);
    printf("%s\n", text ? text : "{}");
    free(text);
    cJSON_Delete(o);
}

static void print_info_text(const char *device, const wdr_info *i)
{
    printf("device:        %s\nboard:         %s\nsensor id:     0x%08x\ngeometry:      %ux%u\n", device, i->name,
           i->sensor_id, i->width, i->height);
    printf("adc/dac bits:  %u/%u\nrow time:      %u ns\nprotocol:      %u.%u\n", i->adc_bits, i->dac_bits,
           i->row_time_ns, i->proto_major, i->proto_minor);
    if (i->fw_slot > 1) /* not booted from a signed image: the firmware's built-in version */
        printf("firmware:      %u.%u (not booted from an image slot)\n", i->fw_major, i->fw_minor);
    else {
        wdr_image_version v = {(uint8_t)i->fw_major, (uint8_t)i->fw_minor, i->fw_patch, i->fw_build};
        char ver[48];
        wdr_fw_version_format(&v, ver, sizeof ver); /* as fw info and fw status write it */
        printf("firmware:      %s, slot %s%s\n", ver, i->fw_slot ? "B" : "A",
               i->fw_flags & 1 ? ", test boot (wdrctl fw confirm keeps it)" : "");
    }
    printf("max payload:   %u bytes\nLUT capacity:  %u bytes\nCAL capacity:  %u bytes\nsimulated:     %s\n",
           i->max_payload, i->lut_capacity, i->cal_capacity, (i->caps & WDR_INFO_CAP_ILLUMINANT) ? "yes" : "no");
}

int cmd_info(int argc, char **argv)
{
    dev_opts o;
    wdrctl_conn conn;
    int rc = parse_opts(argc, argv, &wdrctl_cmd_info, &o);
    if (rc != EX_OK || (rc = connect_opts(&o, &conn)) != EX_OK)
        return rc;
    (o.json ? print_info_json : print_info_text)(wdr_transport_name(conn.t), &conn.c->info);
    wdrctl_disconnect(&conn);
    return EX_OK;
}

static const char *slot_name(uint8_t slot) { return slot == 0 ? "A" : slot == 1 ? "B" : "none"; }

static const char *const state_names[] = {"idle", "reset", "integrate", "readout"};

static const char *upload_name(uint8_t kind)
{
    return kind == WDR_KIND_LUT ? "LUT" : kind == WDR_KIND_CAL ? "calibration" : "none";
}

/* The limit that holds auto exposure's key short of the scene, or NULL. */
static const char *exposure_held(const wdr_status_report *s)
{
    if (s->exposure_flags & WDR_EXPO_HELD_DAC_RATE)
        return "dac_rate";
    return s->exposure_flags & WDR_EXPO_HELD_INTEGRATION ? "longest_integration" : NULL;
}

static void print_status_text(const wdr_status_report *s)
{
    printf("state:         %s\n", s->state < 4 ? state_names[s->state] : "?");
    printf("LUT:           slot %s, seq %u, crc %08x\n", slot_name(s->lut_slot), s->lut_seq, s->lut_crc);
    printf("calibration:   slot %s, seq %u, crc %08x\n", slot_name(s->cal_slot), s->cal_seq, s->cal_crc);
    printf("upload:        %s, %u bytes received\n", upload_name(s->upload_kind), s->upload_received);
    printf("frames:        %u\nintegration:   %u ns\nframe time:    %u ns\nboard time:    %llu ns\n", s->frames,
           s->integration_ns, s->frame_time_ns, (unsigned long long)s->time_ns);
    printf("rx skipped:    %u bytes\nrx bad CRC:    %u frames\n", s->rx_skipped, s->rx_bad_crc);
    printf("exposure:      %s%s, key x%.4g (gain %+.3f ln), tick %u ps, last error %+.3f ln\n",
           s->exposure_auto ? "auto" : "fixed", s->exposure_flags & 1 ? "" : " (LUT without exposure table)",
           exp(s->key_gain_q8 / 256.0), s->key_gain_q8 / 256.0, s->tick_ps, s->last_error_q8 / 256.0);
    if (exposure_held(s))
        printf("exposure held: by the %s: the scene is %s than this LUT can be exposed for\n",
               s->exposure_flags & WDR_EXPO_HELD_DAC_RATE ? "DAC's rate (its shortest step)" : "longest integration",
               s->exposure_flags & WDR_EXPO_HELD_DAC_RATE ? "brighter" : "darker");
}

static void add_slot(cJSON *o, const char *name, uint8_t slot, uint32_t seq, uint32_t crc)
{
    char hex[16];
    cJSON *t = cJSON_AddObjectToObject(o, name);
    cJSON_AddStringToObject(t, "slot", slot_name(slot));
    cJSON_AddNumberToObject(t, "seq", seq);
    snprintf(hex, sizeof hex, "%08x", crc);
    cJSON_AddStringToObject(t, "crc", hex);
}

static void print_status_json(const wdr_status_report *s)
{
    cJSON *o = cJSON_CreateObject();
    cJSON_AddStringToObject(o, "state", s->state < 4 ? state_names[s->state] : "?");
    add_slot(o, "lut", s->lut_slot, s->lut_seq, s->lut_crc);
    add_slot(o, "calibration", s->cal_slot, s->cal_seq, s->cal_crc);
    cJSON_AddStringToObject(o, "upload", upload_name(s->upload_kind));
    cJSON_AddNumberToObject(o, "upload_received", s->upload_received);
    cJSON_AddNumberToObject(o, "frames", s->frames);
    cJSON_AddNumberToObject(o, "integration_ns", s->integration_ns);
    cJSON_AddNumberToObject(o, "frame_time_ns", s->frame_time_ns);
    cJSON_AddNumberToObject(o, "board_time_ns", (double)s->time_ns);
    cJSON_AddNumberToObject(o, "rx_skipped", s->rx_skipped);
    cJSON_AddNumberToObject(o, "rx_bad_crc", s->rx_bad_crc);
    cJSON_AddStringToObject(o, "exposure", s->exposure_auto ? "auto" : "fixed");
    cJSON_AddBoolToObject(o, "exposure_table", s->exposure_flags & 1);
    if (exposure_held(s))
        cJSON_AddStringToObject(o, "exposure_held", exposure_held(s));
    else
        cJSON_AddNullToObject(o, "exposure_held");
    cJSON_AddNumberToObject(o, "key_scale", exp(s->key_gain_q8 / 256.0));
    cJSON_AddNumberToObject(o, "tick_ps", s->tick_ps);
    cJSON_AddNumberToObject(o, "last_error_ln", s->last_error_q8 / 256.0);
    char *text = cJSON_Print(o);
    printf("%s\n", text ? text : "{}");
    free(text);
    cJSON_Delete(o);
}

int cmd_status(int argc, char **argv)
{
    dev_opts o;
    wdrctl_conn conn;
    wdr_status_report s;
    int rc = parse_opts(argc, argv, &wdrctl_cmd_status, &o);
    if (rc != EX_OK || (rc = connect_opts(&o, &conn)) != EX_OK)
        return rc;
    rc = wdr_client_status(conn.c, &s);
    if (rc == WDR_OK)
        (o.json ? print_status_json : print_status_text)(&s);
    int code = rc == WDR_OK ? EX_OK : wdrctl_conn_fail(&conn, rc);
    wdrctl_disconnect(&conn);
    return code;
}

/* ---- Uploads ------------------------------------------------------------------------------------ */

static int read_table_file(const char *path, uint8_t **buf, size_t *len)
{
    int rc = wdr_read_file(path, buf, len);
    if (rc)
        return wdrctl_fail(rc == WDR_E_IO ? EX_NOINPUT : EX_OSERR, "cannot read %s: %s", path,
                           rc == WDR_E_IO ? strerror(errno) : "out of memory");
    if (*len == 0) {
        free(*buf);
        return wdrctl_fail(EX_DATAERR, "%s: empty file", path);
    }
    return EX_OK;
}

static void upload_progress(void *ctx, size_t done, size_t total)
{
    fprintf(stderr, "\r%s: %3d%% (%zu/%zu bytes)%s", (const char *)ctx, (int)(100.0 * (double)done / (double)total),
            done, total, done == total ? "\n" : "");
}

/* Check a table here first, so a broken file gets a message naming it rather than a status. */
static int verify_table(int kind, const char *path, const uint8_t *buf, size_t len, const wdr_info *info)
{
    int rc;
    if (kind == WDR_KIND_LUT) {
        wdr_lut_view v;
        rc = wdr_lut_parse(buf, len, &v);
        if (rc == WDR_OK && v.h.dac_bits != info->dac_bits)
            return wdrctl_fail(EX_DATAERR, "%s: LUT made for a %u-bit DAC, the board has %u bits", path, v.h.dac_bits,
                               info->dac_bits);
    } else {
        wdr_cal_view v;
        rc = wdr_cal_parse(buf, len, &v);
        if (rc == WDR_OK)
            rc = wdr_cal_check_geometry(&v, info->sensor_id, info->width, info->height);
    }
    if (rc != WDR_OK)
        return wdrctl_fail(EX_DATAERR, "%s: not a valid %s table for this board: %s", path,
                           kind == WDR_KIND_LUT ? "LUT" : "calibration", wdr_strerror(rc));
    return EX_OK;
}

int wdrctl_commit_outcome(wdrctl_conn *conn, const char *address, int kind, const uint8_t *table, size_t len)
{
    const char *what = kind == WDR_KIND_LUT ? "LUT" : "calibration table";
    fprintf(stderr, "wdrctl: %s; the %s was sent in full, asking the board whether it took it\n", conn->c->err, what);
    int timeout = conn->c->timeout_ms, retries = conn->c->retries;
    wdrctl_disconnect(conn); /* the board serves one host: free it for the question */
    wdrctl_conn again;
    wdr_status_report st;
    if (connect_waiting(address, timeout, retries, 3000, &again) != EX_OK)
        return wdrctl_fail(EX_TEMPFAIL, "outcome unknown: the board did not answer again; run 'wdrctl status' to see "
                           "whether the %s with CRC %08x is active", what, wdr_crc32(0, table, len));
    int rc = wdr_client_status(again.c, &st);
    uint32_t want = wdr_crc32(0, table, len), have = kind == WDR_KIND_LUT ? st.lut_crc : st.cal_crc;
    uint8_t slot = kind == WDR_KIND_LUT ? st.lut_slot : st.cal_slot;
    int code;
    if (rc != WDR_OK)
        code = wdrctl_fail(EX_TEMPFAIL, "outcome unknown: STATUS failed (%s); run 'wdrctl status'", again.c->err);
    else if (slot != WDR_SLOT_NONE && have == want) {
        printf("%zu bytes stored in slot %s, crc %08x (the board reports it active after the link failed)\n", len,
               slot_name(slot), have);
        code = EX_OK;
    } else
        code = wdrctl_fail(EX_IOERR, "upload failed: the board still runs the previous %s (CRC %08x, not %08x)", what,
                           have, want);
    wdrctl_disconnect(&again);
    return code;
}

static int upload(int argc, char **argv, int kind, const cli_command *command)
{
    const char *cmd = command->name;
    dev_opts o;
    wdrctl_conn conn;
    uint8_t *buf = NULL;
    size_t len = 0;
    int rc = parse_opts(argc, argv, command, &o);
    if (rc != EX_OK || (rc = read_table_file(o.args[0], &buf, &len)) != EX_OK)
        return rc;
    if ((rc = connect_opts(&o, &conn)) != EX_OK) {
        free(buf);
        return rc;
    }
    if (!o.no_verify)
        rc = verify_table(kind, o.args[0], buf, len, &conn.c->info);
    wdr_commit_reply reply;
    int up = rc == EX_OK ? wdr_client_upload(conn.c, kind, buf, len, wdrctl_show_progress() ? upload_progress : NULL,
                                             (void *)cmd, &reply)
                         : WDR_OK;
    if (rc == EX_OK && up != WDR_OK)
        rc = conn.c->commit_unknown ? wdrctl_commit_outcome(&conn, o.device, kind, buf, len)
                                    : wdrctl_conn_fail(&conn, up);
    else if (rc == EX_OK)
        printf("%s: %zu bytes stored in slot %s, seq %u, crc %08x (verified)\n", o.args[0], len,
               slot_name(reply.slot), reply.seq, reply.crc);
    wdrctl_disconnect(&conn);
    free(buf);
    return rc;
}

int cmd_lut_upload(int argc, char **argv) { return upload(argc, argv, WDR_KIND_LUT, &wdrctl_cmd_lut_upload); }

int cmd_cal_upload(int argc, char **argv) { return upload(argc, argv, WDR_KIND_CAL, &wdrctl_cmd_cal_upload); }

/* ---- Small requests ------------------------------------------------------------------------------- */

static int simple_request(dev_opts *o, uint8_t opcode, const uint8_t *payload, uint32_t len, const char *done)
{
    wdrctl_conn conn;
    int rc = connect_opts(o, &conn);
    if (rc != EX_OK)
        return rc;
    int r = wdr_client_request(conn.c, opcode, payload, len);
    rc = r == WDR_OK ? EX_OK : wdrctl_conn_fail(&conn, r);
    if (rc == EX_OK)
        printf("%s\n", done);
    wdrctl_disconnect(&conn);
    return rc;
}

int cmd_lut_select(int argc, char **argv)
{
    dev_opts o;
    int rc = parse_opts(argc, argv, &wdrctl_cmd_lut_select, &o);
    if (rc != EX_OK)
        return rc;
    const char *s = o.args[0];
    uint8_t slot = !strcmp(s, "A") || !strcmp(s, "a") ? 0 : !strcmp(s, "B") || !strcmp(s, "b") ? 1 : WDR_SLOT_NEWEST;
    if (slot == WDR_SLOT_NEWEST && strcmp(s, "newest"))
        return wdrctl_fail(EX_USAGE, "lut select: slot must be A, B or newest, got '%s'", s);
    return simple_request(&o, WDR_CMD_LUT_SELECT, &slot, 1, "LUT selected");
}

int cmd_integration(int argc, char **argv)
{
    dev_opts o;
    double ns = 0;
    int rc = parse_opts(argc, argv, &wdrctl_cmd_integration, &o);
    if (rc != EX_OK || (rc = parse_arg("integration", "NS (0: the LUT's own)", o.args[0], 0, WDR_PROTO_MAX_INTEGRATION_NS, &ns)) != EX_OK)
        return rc;
    uint8_t p[4];
    wdr_put_u32(p, (uint32_t)ns);
    return simple_request(&o, WDR_CMD_SET_INTEGRATION, p, 4, "integration time set");
}

int cmd_exposure(int argc, char **argv)
{
    dev_opts o;
    int rc = parse_opts(argc, argv, &wdrctl_cmd_exposure, &o);
    if (rc != EX_OK)
        return rc;
    uint8_t mode = !strcmp(o.args[0], "auto") ? 1 : 0;
    if (!mode && strcmp(o.args[0], "fixed"))
        return wdrctl_fail(EX_USAGE, "exposure: must be auto or fixed, got '%s'", o.args[0]);
    return simple_request(&o, WDR_CMD_SET_EXPOSURE, &mode, 1, mode ? "auto exposure on" : "exposure fixed");
}

int cmd_sim_illuminant(int argc, char **argv)
{
    dev_opts o;
    wdrctl_conn conn;
    double amps = 0;
    int rc = parse_opts(argc, argv, &wdrctl_cmd_sim_illuminant, &o);
    int scene = rc == EX_OK && !strcmp(o.args[0], "scene");
    if (rc == EX_OK && !scene)
        rc = parse_arg("sim illuminant", "AMPS (or 'scene')", o.args[0], 0, HUGE_VAL, &amps);
    if (rc != EX_OK || (rc = connect_opts(&o, &conn)) != EX_OK)
        return rc;
    int r = scene ? wdr_client_restore_scene(conn.c) : wdr_client_set_illuminant(conn.c, amps);
    rc = r == WDR_OK ? EX_OK : wdrctl_conn_fail(&conn, r);
    if (rc == EX_OK && scene)
        printf("the pixels see the scene again\n");
    else if (rc == EX_OK)
        printf("illuminant set to %g A on every pixel (wdrctl sim illuminant scene: back to the scene)\n", amps);
    wdrctl_disconnect(&conn);
    return rc;
}

/* ---- Capture -------------------------------------------------------------------------------------- */

typedef struct capture_job {
    const dev_opts *o;
    const wdr_info *info;
    double *sum;          /* --average */
    uint32_t frames;
    int err;              /* sysexits of a failed write */
    int progress;
} capture_job;

/* "out.png" -> "out-0003.png" for frame 3 of several. */
static void frame_path(const char *out, uint32_t index, int several, char *path, size_t cap)
{
    const char *dot = strrchr(out, '.');
    if (!several || !dot)
        snprintf(path, cap, "%s", out);
    else
        snprintf(path, cap, "%.*s-%04u%s", (int)(dot - out), out, index, dot);
}

/* Codes (or averaged codes) to the file: PFM keeps codes as floats; PNG scales the ADC range to
 * 8 or 16 bits unless --raw; --negate flips it so that brighter light looks brighter. */
static int write_image(const capture_job *j, const char *path, const double *codes)
{
    const dev_opts *o = j->o;
    int w = j->info->width, h = j->info->height;
    double full = (double)((1u << j->info->adc_bits) - 1u);
    size_t n = (size_t)w * (size_t)h;
    char err[320];
    int rc;
    if (wdr_path_has_ext(path, ".pfm")) {
        float *f = malloc(n * sizeof *f);
        if (!f)
            return wdrctl_fail(EX_OSERR, "out of memory");
        for (size_t i = 0; i < n; i++)
            f[i] = (float)(o->negate ? full - codes[i] : codes[i]);
        rc = wdr_pfm_write(path, f, w, h, err, sizeof err);
        free(f);
    } else {
        uint16_t *px = malloc(n * sizeof *px);
        if (!px)
            return wdrctl_fail(EX_OSERR, "out of memory");
        double top = o->raw ? full : o->bits == 8 ? 255.0 : 65535.0;
        for (size_t i = 0; i < n; i++) {
            double v = (o->negate ? full - codes[i] : codes[i]) * top / full;
            px[i] = (uint16_t)lround(v < 0 ? 0 : v > top ? top : v);
        }
        rc = wdr_png_write_gray(path, px, w, h, o->raw ? 16 : o->bits, err, sizeof err);
        free(px);
    }
    return rc == WDR_OK ? EX_OK : wdrctl_fail(rc == WDR_E_IO ? EX_CANTCREAT : EX_SOFTWARE, "%s", err);
}

static int on_captured(void *ctx, const wdr_frame *f)
{
    capture_job *j = ctx;
    size_t n = (size_t)f->width * f->height;
    if (j->progress)
        fprintf(stderr, "\rcapture: frame %u/%d", j->frames + 1, j->o->count);
    if (j->o->average) {
        for (size_t i = 0; i < n; i++)
            j->sum[i] += f->codes[i];
    } else {
        char path[1024];
        for (size_t i = 0; i < n; i++)
            j->sum[i] = f->codes[i];
        frame_path(j->o->out, j->frames, j->o->count > 1, path, sizeof path);
        j->err = write_image(j, path, j->sum);
    }
    j->frames++;
    return j->err == EX_OK ? WDR_OK : WDR_E_IO;
}

static int check_output_name(const char *cmd, const char *out)
{
    char err[300];
    if (!out)
        return wdrctl_fail(EX_USAGE, "%s: -o FILE (.png or .pfm) is required", cmd);
    if (wdr_output_name_check(out, ".png .pfm", err, sizeof err))
        return wdrctl_fail(EX_USAGE, "%s: %s", cmd, err);
    return EX_OK;
}

static int run_capture(const dev_opts *o, wdrctl_conn *conn)
{
    const wdr_info *info = &conn->c->info;
    size_t n = (size_t)info->width * info->height;
    capture_job j = {.o = o, .info = info, .progress = wdrctl_show_progress() && o->count > 1};
    uint16_t *codes = malloc(n * sizeof *codes);
    j.sum = calloc(n, sizeof *j.sum);
    if (!codes || !j.sum) {
        free(codes);
        free(j.sum);
        return wdrctl_fail(EX_OSERR, "out of memory for a %ux%u frame", info->width, info->height);
    }
    int r = wdr_client_capture(conn->c, (uint32_t)o->count, codes, on_captured, &j);
    if (j.progress)
        fputc('\n', stderr);
    int rc = j.err != EX_OK ? j.err : r != WDR_OK ? wdrctl_conn_fail(conn, r) : EX_OK;
    if (rc == EX_OK && o->average) {
        for (size_t i = 0; i < n; i++)
            j.sum[i] /= o->count;
        rc = write_image(&j, o->out, j.sum);
    }
    if (rc == EX_OK)
        fprintf(stderr, "wdrctl: captured %u frame(s) of %ux%u into %s%s\n", j.frames, info->width, info->height,
                o->out, o->count > 1 && !o->average ? " (numbered)" : "");
    free(codes);
    free(j.sum);
    return rc;
}

int cmd_capture(int argc, char **argv)
{
    dev_opts o;
    wdrctl_conn conn;
    int rc = parse_opts(argc, argv, &wdrctl_cmd_capture, &o);
    if (rc != EX_OK || (rc = check_output_name("capture", o.out)) != EX_OK || (rc = connect_opts(&o, &conn)) != EX_OK)
        return rc;
    o.count = o.count ? o.count : 1;
    rc = run_capture(&o, &conn);
    wdrctl_disconnect(&conn);
    return rc;
}

/* ---- Stream ----------------------------------------------------------------------------------------- */

static volatile int stream_stop;

static void on_signal(int sig)
{
    (void)sig;
    stream_stop = 1;
}

typedef struct stream_job {
    const dev_opts *o;
    uint32_t frames;
    int64_t t0_ms;
    wdr_v4l2_out *v4l2; /* --v4l2, or NULL */
    int err;            /* sysexits of a failed V4L2 write */
} stream_job;

static int on_streamed(void *ctx, const wdr_frame *f)
{
    stream_job *s = ctx;
    size_t n = (size_t)f->width * f->height;
    double sum = 0;
    uint16_t lo = 0xffff, hi = 0;
    for (size_t i = 0; i < n; i++) {
        sum += f->codes[i];
        lo = f->codes[i] < lo ? f->codes[i] : lo;
        hi = f->codes[i] > hi ? f->codes[i] : hi;
    }
    printf("frame %u  mean %.2f  min %u  max %u\n", f->end.frame, sum / (double)n, lo, hi);
    fflush(stdout);
    char err[320];
    if (s->v4l2 && wdr_v4l2_write(s->v4l2, f->codes, err, sizeof err) != WDR_OK) {
        s->err = wdrctl_fail(EX_IOERR, "stream: %s: %s", s->o->v4l2, err);
        return WDR_E_IO;
    }
    s->frames++;
    double elapsed = (double)(wdr_transport_now_ms() - s->t0_ms) / 1000.0;
    if ((s->o->count > 0 && s->frames >= (uint32_t)s->o->count) || (s->o->seconds > 0 && elapsed >= s->o->seconds))
        stream_stop = 1;
    return WDR_OK;
}

/* Frames per second as num/den: --fps, else the board's last frame time (STATUS), else its
 * integration and readout. */
static void stream_rate(const dev_opts *o, wdrctl_conn *conn, uint32_t *num, uint32_t *den)
{
    wdr_status_report st;
    const wdr_info *in = &conn->c->info;
    uint64_t ns = 0;
    if (wdr_client_status(conn->c, &st) == WDR_OK)
        ns = st.frame_time_ns ? st.frame_time_ns : st.integration_ns + (uint64_t)in->row_time_ns * in->height;
    if (o->fps > 0)
        *num = (uint32_t)lround(o->fps * 1000), *den = 1000;
    else if (ns)
        *num = 1000000, *den = (uint32_t)((ns + 500) / 1000); /* microseconds per frame */
    else
        *num = 10, *den = 1;
}

static int open_v4l2(const dev_opts *o, wdrctl_conn *conn, wdr_v4l2_out *v)
{
    const wdr_info *in = &conn->c->info;
    char err[512];
    uint32_t num, den;
    stream_rate(o, conn, &num, &den);
    int rc = wdr_v4l2_open(v, o->v4l2, (wdr_v4l2_format)o->v4l2_format, in->width, in->height, in->adc_bits, num,
                           den, err, sizeof err);
    if (rc != WDR_OK)
        return wdrctl_fail(rc == WDR_E_IO ? EX_CANTCREAT : rc == WDR_E_NOMEM ? EX_OSERR : EX_UNAVAILABLE, "stream: %s",
                           err);
    if (v->fps_num)
        fprintf(stderr, "wdrctl: streaming %ux%u %s into %s at %.3g frames/s (%u bytes per line)%s\n", in->width,
                in->height, wdr_v4l2_format_name(v->format), o->v4l2, (double)v->fps_num / v->fps_den,
                v->bytesperline, v->is_device ? "" : ": raw frames, not a V4L2 device");
    else
        fprintf(stderr, "wdrctl: streaming %ux%u %s into %s (the device sets no frame rate)\n", in->width, in->height,
                wdr_v4l2_format_name(v->format), o->v4l2);
    return EX_OK;
}

int cmd_stream(int argc, char **argv)
{
    dev_opts o;
    wdrctl_conn conn;
    wdr_v4l2_out v4l2;
    int rc = parse_opts(argc, argv, &wdrctl_cmd_stream, &o);
    if (rc == EX_OK && !o.v4l2 && (o.fps > 0 || o.v4l2_format))
        rc = wdrctl_fail(EX_USAGE, "stream: --format and --fps go with --v4l2 DEV");
    if (rc != EX_OK || (rc = connect_opts(&o, &conn)) != EX_OK)
        return rc;
    if (o.v4l2 && (rc = open_v4l2(&o, &conn, &v4l2)) != EX_OK) {
        wdrctl_disconnect(&conn);
        return rc;
    }
    uint16_t *codes = malloc((size_t)conn.c->info.width * conn.c->info.height * sizeof *codes);
    stream_job s = {.o = &o, .t0_ms = wdr_transport_now_ms(), .v4l2 = o.v4l2 ? &v4l2 : NULL};
    struct sigaction sa = {.sa_handler = on_signal}, old_int, old_term;
    sigaction(SIGINT, &sa, &old_int);
    sigaction(SIGTERM, &sa, &old_term);
    stream_stop = 0;
    int r = codes ? wdr_client_stream(conn.c, codes, on_streamed, &s, &stream_stop) : WDR_E_NOMEM;
    sigaction(SIGINT, &old_int, NULL);
    sigaction(SIGTERM, &old_term, NULL);
    double secs = (double)(wdr_transport_now_ms() - s.t0_ms) / 1000.0;
    rc = s.err != EX_OK ? s.err
         : r == WDR_OK  ? EX_OK
         : r == WDR_E_NOMEM ? wdrctl_fail(EX_OSERR, "out of memory")
                           : wdrctl_conn_fail(&conn, r);
    fprintf(stderr, "wdrctl: %u frames in %.2f s (%.1f frames/s)\n", s.frames, secs, secs > 0 ? s.frames / secs : 0.0);
    if (s.v4l2)
        wdr_v4l2_close(s.v4l2);
    free(codes);
    wdrctl_disconnect(&conn);
    return rc;
}
