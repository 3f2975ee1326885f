/* wdr-board: the controller firmware on an embedded-Linux board (hal/linux). The same loop as
 * a bare-metal main: the firmware's task, then sleep until an event. Runs in CI on a real
 * kernel in a VM (tests/vm); see hal/linux/README.md. Its pins and devices are build-time data
 * (hal_linux_config.h), so its command line is --help and --version only. */
#include "cli_options.h"
#include "hal_linux_internal.h"
#include "wdr_err.h"
#include "wdr_fw.h"
#include <stdio.h>
#include <sysexits.h>

static wdr_fw fw; /* every buffer of the firmware: static, as on the controller */

static const cli_option no_rows[] = {{0}};
static const cli_command board_command = {
    NULL, NULL, 0, 0, "the controller firmware on an embedded-Linux board", NULL, no_rows, NULL, 0};
static const cli_section sections[] = {
    {"FILES", "The GPIO chip, SPI devices, FunctionFS mount and MTD partition are fixed at build time "
              "(hal/linux/hal_linux_config.h); assemble the USB gadget in configfs first (hal/linux/README.md)."},
    {"EXIT STATUS", "It runs until stopped; 1 when the board's bring-up fails (the message names the device, "
                    "the call and errno), 64 on a bad command line."},
    {"EXAMPLES", "wdr-board &            # on the board, once its USB gadget is assembled"},
    {"SEE ALSO", "wdrctl(1), wdr-simboard(1)"},
    {NULL, NULL}};
static const cli_program board_program = {
    .name = "wdr-board",
    .summary = "the wdrcam controller firmware on an embedded-Linux board",
    .description = "wdr-board drives the sensor through libgpiod control lines, spidev DAC and ADC, FunctionFS "
                   "bulk endpoints and an MTD flash partition, and runs the firmware's task loop.",
    .single = &board_command,
    .sections = sections,
};

int main(int argc, char **argv)
{
    int n_args = 0, done = 0, rc = cli_main_single(&board_program, argc, argv, &(char){0}, &n_args, &done);
    if (rc != EX_OK || done)
        return rc;
    rc = hal_init();
    if (rc != WDR_OK) {
        fprintf(stderr, "wdr-board: board bring-up failed: %s (%s)\n", lx_bringup_error(), wdr_strerror(rc));
        return 1;
    }
    rc = wdr_fw_init(&fw);
    if (rc != WDR_OK)
        fprintf(stderr, "wdr-board: firmware started with: %s\n", wdr_strerror(rc));
    for (;;)
        if (!wdr_fw_task(&fw))
            hal_wait_for_event();
}
