/* Shared set-up for the operator tests: boards by name and operators with defaults. */
#ifndef TEST_SUPPORT_H
#define TEST_SUPPORT_H
#include "board.h"
#include "operators.h"
#include "ramp.h"
#include "wdr_err.h"
#include <stdio.h>
#include <stdlib.h>
#include <math.h>

#include "wdr_test.h"

static inline void load_test_board(const char *name, wdr_board *b)
{
    char path[1024], err[512];
    wdr_board_path(name, path, sizeof path);
    wdr_board_defaults(b);
    if (wdr_board_load(path, b, err, sizeof err)) {
        fprintf(stderr, "cannot load board %s: %s\n", name, err);
        exit(1);
    }
}

static inline int init_default_op(wdr_operator *op, const wdr_board *b, const char *name)
{
    char err[512];
    wdr_lum_stats st;
    wdr_lum_stats_default(b->i_min_a, b->i_center_a, b->i_max_a, b->lum_per_amp, 0.18, &st);
    return wdr_operator_init(op, name, &st, err, sizeof err);
}

#endif
