/* Issue 21 item 1 on other chips than bench_target's: the 9-byte forms (COMPACT and SHIFTED, the
 * better of the two, as `--form auto` would take it) hold 1 % worst analog contrast error on
 * sim-qvga chip seeds other than the tuned one, through the kernel's fixed-point arithmetic
 * (cal_matrix.c: spline, 12 defects planted, temporal noise off, 31 judged currents).
 *
 * The cells are the ones that missed before the table's pad was held past the codes the array
 * reads (cal_basis_reach.c): Schlick seeds 1 and 2 (compact 3.238 / 1.126 %, shifted 4.875 /
 * 4.365 %) and Tumblin-Rushmeier seeds 2 and 3 (shifted 1.787 / 1.088 %); with wdr_cal_basis_held
 * disabled this test fails on all four. Tumblin-Rushmeier seed 1 (shifted 1.209 -> 1.102 % with
 * the pad held) held only once the learner re-picked the sample pixels' shifts between its rounds
 * (cal_basis.c, repick_shifts: 0.855 %); with the re-pick disabled it fails at 1.102 %. Each chip
 * run takes about 10 s (the analog chip only: the 12-bit figures are bench_cal_matrix's), so the other
 * cells are arguments (`drago:2`). A cell listed with a known
 * figure is printed KNOWN while it misses, and fails the test as FIXED when it starts to hold.
 *
 *   test_cal_nine_bytes [op:seed ...]   (default: the cells above) */
#include "cal_matrix.h"
#include "wdr_cal.h"
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define LIMIT_PCT 1.0

typedef struct nine_cell {
    const char *op;
    int seed;
    double known_pct; /* > 0: misses today at this figure */
} nine_cell;

static const nine_cell cells[] = {
    {"schlick", 1, 0},           {"schlick", 2, 0},           {"tumblin_rushmeier", 2, 0},
    {"tumblin_rushmeier", 3, 0}, {"tumblin_rushmeier", 1, 0},
};

/* 0 when the cell holds as listed (or as known), 1 otherwise; prints a line. */
static int check_cell(const nine_cell *c)
{
    const cm_setup s = {.plant_defects = 1, .analog_only = 1}; /* the 12-bit chip: bench_cal_matrix */
    const int forms[2] = {WDR_FORM_COMPACT, WDR_FORM_SHIFTED}, n_coeffs[2] = {4, 4};
    cm_cell out[2];
    if (cm_run_chip(&s, WDR_MODEL_SPLINE, c->op, (uint64_t)c->seed, 1, forms, n_coeffs, 2, out))
        return 1;
    double compact = out[0].side[0].refused ? 1e9 : out[0].side[0].worst_pct,
           shifted = out[1].side[0].refused ? 1e9 : out[1].side[0].worst_pct;
    double best = compact < shifted ? compact : shifted; /* NaN compares false: takes shifted */
    int holds = best <= LIMIT_PCT, known = c->known_pct > 0;
    const char *verdict =
        holds ? (known ? "FIXED: now holds; remove it from cells[]" : "ok") : (known ? "KNOWN" : "FAIL (limit 1 %)");
    printf("%-18s seed %d: compact %.3f %%, shifted %.3f %% (analog, converters off): %s\n", c->op, c->seed, compact,
           shifted, verdict);
    fflush(stdout);
    return holds == known;
}

int main(int argc, char **argv)
{
    int failed = 0;
    if (argc > 1) {
        for (int i = 1; i < argc; i++) {
            char op[32];
            int seed;
            if (sscanf(argv[i], "%31[a-z_]:%d", op, &seed) != 2) {
                fprintf(stderr, "test_cal_nine_bytes: argument '%s' is not op:seed\n", argv[i]);
                return 64;
            }
            nine_cell c = {op, seed, 0};
            failed += check_cell(&c);
        }
    } else
        for (size_t i = 0; i < sizeof cells / sizeof cells[0]; i++)
            failed += check_cell(&cells[i]);
    return failed ? 1 : 0;
}
