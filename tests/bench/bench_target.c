/* What a Cortex-M7 controller pays per pixel, per table form: instructions for the correction
 * alone and for the whole row path (correction, ROW framing, CRC), counted on QEMU's mps2-an500
 * under -icount shift=0 (the image tests/bench/bench_target_arm/main_bench.c; exact and
 * repeatable), beside table bytes per pixel, the VGA frame rate and table bandwidth those would
 * allow on a 480 MHz part, and each form's worst contrast error on the seven operators
 * (bench_target_study.h). Instructions are not cycles: the M7 dual-issues some pairs, and table
 * reads from external SDRAM or quad-SPI flash add stalls; the frame rate below assumes one
 * instruction per cycle and no stall, so it is an upper bound for the pipeline, not a promise.
 *
 *   bench_target [--quick] [--qemu QEMU --image wdr_bench_mps2.elf --data target_data --dir DIR]
 *                [--counts FILE]
 * --counts writes the measured instruction counts, one "form n_coeffs corr row" line per form, for
 * test_study_m7 to hold the study's copy (host/study/study_m7.c) to them.
 * Without --image only the accuracy half runs; --quick judges Drago alone, not all seven. */
#include "bench_target_study.h"
#include <signal.h>
#include <string.h>
#include <sys/wait.h>
#include <unistd.h>

#define BENCH_W 640
#define BENCH_H 8
#define CPU_HZ 480e6
#define VGA_PIXELS (640.0 * 480.0)

typedef struct form_row {
    const char *name; /* as main_bench.c prints it */
    int form, n;
    double bytes_per_px, corr, row, worst;
} form_row;

static form_row forms[] = {
    {"identity", WDR_FORM_IDENTITY, 0, 0, NAN, NAN, NAN}, {"moebius", WDR_FORM_MOEBIUS, 3, 13, NAN, NAN, NAN},
    {"poly", WDR_FORM_POLY, 5, 21, NAN, NAN, NAN},        {"basis", WDR_FORM_BASIS, 8, 33, NAN, NAN, NAN},
    {"compact", WDR_FORM_COMPACT, 4, 9, NAN, NAN, NAN},     {"shifted", WDR_FORM_SHIFTED, 4, 9, NAN, NAN, NAN},
};
#define N_FORMS (sizeof forms / sizeof forms[0])

static int run(const char *cmd)
{
    int rc = system(cmd);
    return rc ? (fprintf(stderr, "bench_target: failed: %s\n", cmd), 1) : 0;
}

/* Tables and frames as the target test builds them, one 640-pixel row block per row. */
static int make_inputs(const char *data, const char *dir)
{
    char cmd[1024];
    snprintf(cmd, sizeof cmd, "%s frames %s/f.bin %d %d 1", data, dir, BENCH_W, BENCH_H);
    if (run(cmd))
        return 1;
    for (size_t i = 1; i < N_FORMS; i++) {
        snprintf(cmd, sizeof cmd, "%s cal %s %s/%s.bin %d %d", data, forms[i].name, dir, forms[i].name, BENCH_W,
                 BENCH_H);
        if (run(cmd))
            return 1;
    }
    return 0;
}

static void parse_line(const char *line)
{
    char name[32];
    unsigned corr, row;
    if (sscanf(line, "form %31s %u %u", name, &corr, &row) != 3)
        return;
    for (size_t i = 0; i < N_FORMS; i++)
        if (!strcmp(name, forms[i].name))
            forms[i].corr = corr / 1000.0, forms[i].row = row / 1000.0;
}

/* Boot the bench image with the tables in PSRAM (2 MiB apart) and read its UART until "done". */
static int count_instructions(const char *qemu, const char *image, const char *dir)
{
    char loaders[5][300], frames[300];
    snprintf(frames, sizeof frames, "loader,file=%s/f.bin,addr=0x60800000,force-raw=on", dir);
    for (int i = 0; i < 5; i++) /* 1 MiB apart (main_bench.c's TABLE_AT): a 640 x 8 table is < 200 KB */
        snprintf(loaders[i], sizeof loaders[i], "loader,file=%s/%s.bin,addr=0x%x,force-raw=on", dir, forms[i + 1].name,
                 0x60000000u + (unsigned)i * 0x100000u);
    int pipefd[2];
    if (pipe(pipefd))
        return 1;
    pid_t pid = fork();
    if (pid == 0) {
        dup2(pipefd[1], 1);
        close(pipefd[0]);
        execl(qemu, qemu, "-M", "mps2-an500", "-nographic", "-monitor", "none", "-icount", "shift=0", "-kernel", image,
              "-device", frames, "-device", loaders[0], "-device", loaders[1], "-device", loaders[2], "-device",
              loaders[3], "-device", loaders[4], "-serial", "stdio", (char *)NULL);
        _exit(127);
    }
    close(pipefd[1]);
    FILE *in = fdopen(pipefd[0], "r");
    char line[256];
    int done = 0;
    while (in && !done && fgets(line, sizeof line, in)) {
        parse_line(line);
        done = !strncmp(line, "done", 4);
    }
    kill(pid, SIGTERM);
    waitpid(pid, NULL, 0);
    if (in)
        fclose(in);
    return done ? 0 : (fprintf(stderr, "bench_target: the bench image did not finish\n"), 1);
}

/* Worst over the operators, per form; Moebius with the 3-parameter model it is exact for. */
static int judge(int n_ops)
{
    for (int o = 0; o < n_ops; o++) {
        study_chip c;
        wdr_cal_result spline, simple3;
        int op = n_ops == STUDY_OPS ? o : 3; /* --quick: Tumblin-Rushmeier, the hardest for the compact forms */
        if (study_open(&c, study_ops[op]) || study_fit(&c, WDR_MODEL_SPLINE, 19, &spline))
            return 1;
        /* simple3 refuses the operators it cannot serve (Drago, Tumblin-Rushmeier, logarithmic):
         * Moebius, exact only for simple3, has no figure there */
        int simple3_refused = study_fit(&c, WDR_MODEL_SIMPLE3, 3, &simple3) != 0;
        printf("  %-18s", study_ops[op]);
        for (size_t i = 1; i < N_FORMS; i++) {
            if (forms[i].form == WDR_FORM_MOEBIUS && simple3_refused) {
                printf("  %s refused (simple3)", forms[i].name);
                continue;
            }
            double w =
                study_worst(&c, forms[i].form == WDR_FORM_MOEBIUS ? &simple3 : &spline, forms[i].form, forms[i].n);
            forms[i].worst = isnan(forms[i].worst) || w > forms[i].worst ? w : forms[i].worst;
            printf("  %s %.3f %%", forms[i].name, w);
        }
        printf("\n");
        fflush(stdout);
        wdr_cal_result_free(&spline);
        if (!simple3_refused)
            wdr_cal_result_free(&simple3);
        study_close(&c);
    }
    return 0;
}

static void print_table(void)
{
    printf("\n%-9s %5s %10s %10s %12s %14s %12s %10s\n", "form", "B/px", "corr insn", "row insn", "worst err %",
           "VGA fps@480M", "table MB/s", "VGA table");
    for (size_t i = 0; i < N_FORMS; i++) {
        const form_row *f = &forms[i];
        double fps = CPU_HZ / (f->row * VGA_PIXELS);
        printf("%-9s %5.0f %10.2f %10.2f %12.3f %14.1f %12.1f %8.2f MB\n", f->name, f->bytes_per_px, f->corr, f->row,
               f->worst, fps, fps * f->bytes_per_px * VGA_PIXELS / 1e6, f->bytes_per_px * VGA_PIXELS / 1e6);
    }
    printf("(insn = instructions per pixel on the Cortex-M7, counted by QEMU -icount shift=0; not cycles: the M7\n"
           " dual-issues, external-memory table reads stall. fps = 480e6 / (row insn x 640 x 480), an upper bound;\n"
           " table MB/s = the reads that frame rate needs. Worst err: contrast error, analog, worst over operators;\n"
           " Moebius from the 3-parameter model. basis = 8 functions; compact = 4, int16; shifted = compact\n"
           " with a code shift per pixel in its flag byte, format 1.3.)\n");
}

/* Bytes of a whole stored table (header, shared block, rows) for a sensor of w x h, per form. */
static double table_bytes(const form_row *f, uint16_t w, uint16_t h)
{
    switch (f->form) {
    case WDR_FORM_IDENTITY: return 0;
    case WDR_FORM_BASIS: return (double)wdr_cal_size_basis(w, h, 8, WDR_CAL_MAX_SHARED_FLOATS / 8);
    case WDR_FORM_COMPACT:
    case WDR_FORM_SHIFTED: return (double)wdr_cal_size_compact(w, h, WDR_CAL_MAX_SHARED_FLOATS / 4);
    default: return (double)wdr_cal_size(w, h, (uint16_t)f->n);
    }
}

static void print_external(void)
{
    printf("\nExternal memory for the table (table flash or SDRAM; the firmware reads one row block at a time):\n");
    printf("%-9s %14s %14s\n", "form", "VGA 640x480", "SXGA 1280x1024");
    for (size_t i = 1; i < N_FORMS; i++)
        printf("%-9s %11.2f MB %11.2f MB\n", forms[i].name, table_bytes(&forms[i], 640, 480) / 1e6,
               table_bytes(&forms[i], 1280, 1024) / 1e6);
    printf("(1280-pixel rows are above the firmware's WDR_FW_MAX_WIDTH of 1024, so that sensor also needs a\n"
           " wider build; the sizes are what its table takes.)\n");
}

static int write_counts(const char *path)
{
    FILE *f = fopen(path, "w");
    if (!f)
        return fprintf(stderr, "bench_target: %s: cannot write\n", path), 1;
    for (size_t i = 0; i < N_FORMS; i++)
        fprintf(f, "%d %d %.2f %.2f\n", forms[i].form, forms[i].n, forms[i].corr, forms[i].row);
    return fclose(f) ? 1 : 0;
}

int main(int argc, char **argv)
{
    const char *qemu = NULL, *image = NULL, *data = NULL, *dir = "/tmp", *counts = NULL;
    int quick = 0;
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--quick"))
            quick = 1;
        else if (i + 1 < argc && !strcmp(argv[i], "--qemu"))
            qemu = argv[++i];
        else if (i + 1 < argc && !strcmp(argv[i], "--image"))
            image = argv[++i];
        else if (i + 1 < argc && !strcmp(argv[i], "--data"))
            data = argv[++i];
        else if (i + 1 < argc && !strcmp(argv[i], "--dir"))
            dir = argv[++i];
        else if (i + 1 < argc && !strcmp(argv[i], "--counts"))
            counts = argv[++i];
        else
            return fprintf(stderr, "bench_target: unknown argument '%s'\n", argv[i]), 64;
    }
    printf("bench_target: worst contrast error per form (analog, 64x48 chip, through the kernel's arithmetic)\n");
    if (judge(quick ? 1 : STUDY_OPS))
        return 1;
    if (qemu && image && data) {
        if (make_inputs(data, dir) || count_instructions(qemu, image, dir) || (counts && write_counts(counts)))
            return 1;
    } else
        printf("bench_target: no --qemu/--image/--data: instruction counts skipped (.ci/test runs them)\n");
    print_table();
    print_external();
    return 0;
}
