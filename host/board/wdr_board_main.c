/* wdr-board: the controller firmware on an embedded-Linux board (hal/linux). The same loop as
 * a bare-metal main: the firmware's task, then sleep until an event, until SIGTERM or SIGINT.
 * The board (chip, lines, SPI devices, MTD partition, FunctionFS mount, sensor) is read from
 * --config at start; see boards/README.md. Runs in CI on real kernels in a VM (tests/vm). */
#include "cli_options.h"
#include "hal_linux_internal.h"
#include "wdr_err.h"
#include "wdr_fw.h"
#include <signal.h>
#include <stddef.h>
#include <stdio.h>
#include <string.h>
#include <sysexits.h>

#define DEFAULT_CONFIG "/etc/wdrcam/board.json"

static wdr_fw fw; /* every buffer of the firmware: static, as on the controller */
static volatile sig_atomic_t stop_signal;

typedef struct board_opts {
    const char *config;
    int self_test, check_config;
} board_opts;

#define O(f) offsetof(board_opts, f)
static const cli_option rows[] = {
    {"config", 'c', CLI_STRING, O(config), "FILE", "the board description (default " DEFAULT_CONFIG ")"},
    {"self-test", 0, CLI_FLAG, O(self_test), NULL,
     "drive each control line and SPI device once, name the first that does not answer, exit"},
    {"check-config", 0, CLI_FLAG, O(check_config), NULL, "only read and check the board description, exit"},
    {0}};
static const cli_command board_command = {
    NULL, NULL, 0, 0, "the controller firmware on an embedded-Linux board", NULL, rows, NULL, 0};
static const cli_section sections[] = {
    {"FILES", DEFAULT_CONFIG ": the board (GPIO chip by path or label, lines by offset or name, spidev "
              "devices and speeds, MTD partition by path or name, FunctionFS mount, sensor); schema and examples "
              "in boards/README.md. The USB gadget is assembled by wdr-gadget(1) (configfs), and the "
              "wdr-board.service unit runs both."},
    {"SIGNALS", "SIGTERM and SIGINT stop it cleanly: the ramp stops, the endpoints close (the kernel unbinds "
                "the gadget), the lines go low, exit 0. Under systemd it reports READY=1 once the descriptors "
                "are written and STOPPING=1 ($NOTIFY_SOCKET, Type=notify)."},
    {"EXIT STATUS", "0 after a stop signal or a passed self-test; 1 when the board's bring-up or the self-test "
                    "fails (the message names the device, the line or call, and errno); 64 on a bad command "
                    "line; 65 on a bad board description (the message names the file, field and value); 66 "
                    "when it cannot be read; 75 after a REBOOT request (the service restarts it)."},
    {"EXAMPLES", "wdr-board --config /etc/wdrcam/board.json --check-config   # the board description only\n"
                 "wdr-board --config /etc/wdrcam/board.json --self-test      # each line and SPI device once"},
    {"SEE ALSO", "wdrctl(1), wdr-simboard(1), wdr-gadget(1), gpioinfo(1)"},
    {NULL, NULL}};
static const cli_program board_program = {
    .name = "wdr-board",
    .summary = "the wdrcam controller firmware on an embedded-Linux board",
    .description = "wdr-board drives the sensor through libgpiod control lines, spidev DAC and ADC, FunctionFS "
                   "bulk endpoints and an MTD flash partition, and runs the firmware's task loop.",
    .single = &board_command,
    .sections = sections,
};

static void on_stop(int sig)
{
    stop_signal = sig;
    lx_wake_from_signal();
}

static void catch_stop_signals(void)
{
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_stop; /* no SA_RESTART: the task loop's poll returns at once */
    sigemptyset(&sa.sa_mask);
    sigaction(SIGTERM, &sa, NULL);
    sigaction(SIGINT, &sa, NULL);
}

static int load_board(const char *file)
{
    static lx_board board;
    char err[400];
    int rc = lx_board_load(file, &board, err, sizeof err);
    if (rc != 0) {
        fprintf(stderr, "wdr-board: %s\n", err);
        return rc == -2 ? EX_NOINPUT : EX_DATAERR;
    }
    lx_board_use(&board);
    return EX_OK;
}

static void print_board(const lx_board *b)
{
    printf("%s: %ux%u, ADC %u bits, DAC %u bits; chip %s, %u lines; DAC %s, ADC %s; flash %s; FunctionFS %s\n",
           b->name, b->width, b->height, b->adc_bits, b->dac_bits, b->gpio_chip, b->n_lines, b->dac.path, b->adc.path,
           b->mtd, b->functionfs);
}

static int run_firmware(void)
{
    catch_stop_signals();
    int rc = hal_init();
    if (rc != WDR_OK) {
        fprintf(stderr, "wdr-board: board bring-up failed: %s (%s)\n", lx_bringup_error(), wdr_strerror(rc));
        return 1;
    }
    rc = wdr_fw_init(&fw);
    if (rc != WDR_OK)
        fprintf(stderr, "wdr-board: firmware started with: %s\n", wdr_strerror(rc));
    lx_notify("READY=1"); /* descriptors written: the gadget can be bound (ExecStartPost) */
    while (!stop_signal)
        if (!wdr_fw_task(&fw))
            hal_wait_for_event();
    lx_notify("STOPPING=1");
    lx_shutdown();
    fprintf(stderr, "wdr-board: stopped on signal %d: ramp stopped, endpoints closed, lines low\n", (int)stop_signal);
    return 0;
}

int main(int argc, char **argv)
{
    board_opts o = {.config = DEFAULT_CONFIG};
    int n_args = 0, done = 0, rc = cli_main_single(&board_program, argc, argv, &o, &n_args, &done);
    if (rc != EX_OK || done)
        return rc;
    rc = load_board(o.config);
    if (rc != EX_OK)
        return rc;
    if (o.check_config) {
        print_board(lx_board_get());
        return EX_OK;
    }
    if (o.self_test)
        return lx_self_test(stdout);
    return run_firmware();
}
