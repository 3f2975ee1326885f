/* The compact forms across chips: worst analog contrast error of COMPACT (4 shared functions) and
 * SHIFTED (the same plus a per-pixel code shift, format 1.3) on every operator, for several chip
 * seeds and two sizes, through the kernel's arithmetic (bench_target_study.h), and the worst case
 * seen per form. One chip is never the answer: a seed may be lucky.
 *
 *   bench_shifted [--quick] [--seeds 11,3,7] [--sizes 64x48,96x72] [--ops drago,...] [--basis]
 * --quick: Tumblin-Rushmeier alone, one seed, 64x48; --basis: basis-8 beside them. */
#include "bench_target_study.h"
#include <string.h>

#define MAX_LIST 8

static int parse_list(const char *s, int *v, int max, int pairs)
{
    int n = 0;
    while (*s && n < max) {
        char *end;
        v[n * (pairs + 1)] = (int)strtol(s, &end, 10);
        if (pairs && *end == 'x')
            v[n * 2 + 1] = (int)strtol(end + 1, &end, 10);
        n++;
        s = *end == ',' ? end + 1 : end;
        if (*end && *end != ',')
            return -1;
    }
    return n;
}

int main(int argc, char **argv)
{
    int seeds[MAX_LIST] = {11, 3, 7}, sizes[2 * MAX_LIST] = {64, 48, 96, 72}, n_seeds = 3, n_sizes = 2;
    int quick = 0, basis = 0;
    const char *ops = NULL; /* a comma-separated subset of study_ops; all by default */
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--quick"))
            quick = 1, n_seeds = 1, n_sizes = 1;
        else if (i + 1 < argc && !strcmp(argv[i], "--ops"))
            ops = argv[++i];
        else if (!strcmp(argv[i], "--basis"))
            basis = 1;
        else if (i + 1 < argc && !strcmp(argv[i], "--seeds"))
            n_seeds = parse_list(argv[++i], seeds, MAX_LIST, 0);
        else if (i + 1 < argc && !strcmp(argv[i], "--sizes"))
            n_sizes = parse_list(argv[++i], sizes, MAX_LIST, 1);
        else
            return fprintf(stderr, "bench_shifted: unknown argument '%s'\n", argv[i]), 64;
        if (n_seeds < 1 || n_sizes < 1)
            return fprintf(stderr, "bench_shifted: bad list '%s'\n", argv[i]), 64;
    }
    const int forms[3] = {WDR_FORM_COMPACT, WDR_FORM_SHIFTED, WDR_FORM_BASIS}, nf = basis ? 3 : 2;
    const char *names[3] = {"compact", "shifted", "basis-8"};
    double worst[STUDY_OPS][3] = {{0}};
    printf("bench_shifted: worst analog contrast error %% (31 currents; 19-level spline fit)\n");
    for (int o = quick ? 3 : 0; o < (quick ? 4 : STUDY_OPS); o++)
        for (int z = 0; z < n_sizes && (!ops || strstr(ops, study_ops[o])); z++)
            for (int s = 0; s < n_seeds; s++) {
                study_chip c;
                wdr_cal_result sp;
                if (study_open_chip(&c, study_ops[o], sizes[2 * z], sizes[2 * z + 1], (uint32_t)seeds[s]) ||
                    study_fit(&c, WDR_MODEL_SPLINE, 19, &sp))
                    return 1;
                printf("  %-18s %3dx%-3d seed %2d", study_ops[o], c.w, c.h, seeds[s]);
                for (int f = 0; f < nf; f++) {
                    double w = study_worst(&c, &sp, forms[f], forms[f] == WDR_FORM_BASIS ? 8 : 4);
                    worst[o][f] = isnan(w) || w > worst[o][f] ? w : worst[o][f];
                    printf("  %s %.3f", names[f], w);
                }
                printf("\n");
                fflush(stdout);
                wdr_cal_result_free(&sp);
                study_close(&c);
            }
    printf("\nworst seen over %d seed(s) x %d size(s):\n%-18s", n_seeds, n_sizes, "operator");
    for (int f = 0; f < nf; f++)
        printf(" %9s", names[f]);
    printf("\n");
    for (int o = quick ? 3 : 0; o < (quick ? 4 : STUDY_OPS); o++) {
        if (ops && !strstr(ops, study_ops[o]))
            continue;
        printf("%-18s", study_ops[o]);
        for (int f = 0; f < nf; f++)
            printf(" %8.3f%%", worst[o][f]);
        printf("\n");
    }
    return 0;
}
