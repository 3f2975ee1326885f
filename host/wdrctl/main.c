/* wdrctl: the host tool. One dispatch table; each command group lives in its own file. */
#include "wdrctl.h"
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

static const wdrctl_command commands[] = {
    {NULL, "operators", cmd_operators, "list tone-mapping operators, parameters and defaults"},
    {"lut", "build", cmd_lut_build,
     "--operator NAME [--param key=value]... [--board FILE] -o LUT.bin [--csv FILE] [--plot FILE.png] [--json]\n"
     "            [--repair] [--timing uniform|stamped] [--entries N] [--dac-bits N] [--curve FILE.csv]\n"
     "            [--l-avg X] [--l-max X] [--l-min X] [--scene-image HDR]"},
    {"lut", "plots", cmd_lut_plots, "[--board FILE] [--outdir DIR]  V_ref(t) and response of every operator"},
    {NULL, "tonemap", cmd_tonemap,
     "--scene FILE [--board B] [--operator NAME] [--param k=v]... [--scene-image HDR] -o SOFT.png\n"
     "            [--capture CAP.pfm --side-by-side OUT.png]"},
    /* Board commands take [--device sim:/path.sock|usb[:BUS-ADDR]] (default $WDR_DEVICE),
     * [--timeout MS] [--retries N] [--wait MS] (wait for a board that is starting). */
    {NULL, "devices", cmd_devices, "list wdrcam USB boards, and the simulated one given by --device"},
    {NULL, "info", cmd_info, "[--json]  board identity and protocol version"},
    {NULL, "status", cmd_status, "[--json]  state, active tables, counters"},
    {"lut", "upload", cmd_lut_upload, "LUT.bin [--no-verify]  store a LUT in flash and play it"},
    {"lut", "select", cmd_lut_select, "A|B|newest  play the LUT of a slot"},
    {"cal", "upload", cmd_cal_upload, "CAL.bin [--no-verify]  store a calibration table in flash and apply it"},
    {NULL, "integration", cmd_integration, "NS  integration time (0: the LUT's own)"},
    {NULL, "capture", cmd_capture,
     "[-n N] -o FILE.png|FILE.pfm [--bits 8|16] [--raw] [--negate] [--average]  N frames (numbered files)"},
    {NULL, "stream", cmd_stream, "[-n N] [--seconds S]  frames back to back, one line each, until Ctrl-C"},
    {"sim", "illuminant", cmd_sim_illuminant, "AMPS  light every pixel of a simulated board uniformly"},
    /* Calibration (cmd_cal.c): a board with --device or $WDR_DEVICE, else the simulator directly. */
    {NULL, "calibrate", cmd_calibrate,
     "[--model spline|simple3|complex4|lsq|polymap] [--currents A,B,..|--levels-file F|--select N] [--frames M]\n"
     "            [--board FILE] [--operator NAME] [--adc on|off] [--dac on|off]\n"
     "            [--device ADDR [--lut LUT.bin] [--upload]] [--out-scale 1..16]\n"
     "            [--form moebius|poly|basis]\n"
     "            -o CAL.bin [--json]"},
    {"fpn", "report", cmd_fpn_report,
     "--outdir DIR [--models spline,simple3,complex4] [--board FILE] [--operator NAME] [--adc on|off]\n"
     "            [--dac on|off] [--json]  FPN contrast error, model error, DSNU/PRNU, histograms, test image"},
    {NULL, "study", cmd_study,
     "[--study FILE.json] [--adc-bits L] [--adc-range LO:HI,..] [--dac-bits L] [--dac-range LO:HI,..]\n"
     "            [--converter-ranges full,fit] [--timing stamped,uniform] [--entries L] [--dac-timer-hz L]\n"
     "            [--operator L] [--param KEY=V1,V2;..] [--model L] [--form auto,moebius,poly,basis] [--coeffs L]\n"
     "            [--coeff-bits 32,16] [--levels L] [--levels-choice log,select] [--frames L] [--image-frames L]\n"
     "            [--size WxH,..] [--range 1e-14:1e-8] [--target 1%] [--fps F] [--jobs 2] [--seed N]\n"
     "            [--outdir DIR] [--no-plots] [--json]  what accuracy costs: every combination (lists: a,b or\n"
     "            A:B[:STEP|:*FACTOR]) on the simulator, the table, Pareto fronts, plots, cheapest design"},
};
#define N_COMMANDS (int)(sizeof commands / sizeof commands[0])

int wdrctl_fail(int code, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    fputs("wdrctl: ", stderr);
    vfprintf(stderr, fmt, ap);
    fputc('\n', stderr);
    va_end(ap);
    return code;
}

int wdrctl_show_progress(void)
{
    const char *ci = getenv("CI");
    return isatty(2) && !(ci && *ci && strcmp(ci, "false"));
}

static void usage(FILE *f)
{
    fprintf(f, "usage: wdrctl COMMAND [options]\n\ncommands:\n");
    for (int i = 0; i < N_COMMANDS; i++)
        fprintf(f, "  %s%s%s %s\n", commands[i].group ? commands[i].group : "", commands[i].group ? " " : "",
                commands[i].name, commands[i].usage);
}

int main(int argc, char **argv)
{
    if (argc < 2 || !strcmp(argv[1], "--help") || !strcmp(argv[1], "-h")) {
        usage(argc < 2 ? stderr : stdout);
        return argc < 2 ? EX_USAGE : EX_OK;
    }
    for (int i = 0; i < N_COMMANDS; i++) {
        const wdrctl_command *c = &commands[i];
        if (!c->group && !strcmp(argv[1], c->name))
            return c->run(argc - 1, argv + 1);
        if (c->group && !strcmp(argv[1], c->group) && argc > 2 && !strcmp(argv[2], c->name))
            return c->run(argc - 2, argv + 2);
    }
    fprintf(stderr, "wdrctl: unknown command '%s%s%s'\n", argv[1], argc > 2 ? " " : "", argc > 2 ? argv[2] : "");
    usage(stderr);
    return EX_USAGE;
}
