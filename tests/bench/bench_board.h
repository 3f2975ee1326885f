/* Shared by the benchmarks that talk to the simulated board: the firmware on the sim HAL,
 * serving a socket from a thread. */
#ifndef BENCH_BOARD_H
#define BENCH_BOARD_H
#include "board.h"
#include "hal.h"
#include "hal_sim_emul.h"
#include "simboard_loop.h"
#include "wdr_err.h"
#include "wdr_scene.h"
#include <pthread.h>
#include <stdio.h>

static void *bench_serve(void *arg)
{
    (void)arg;
    simboard_serve();
    return NULL;
}

static int bench_die(const char *bench, const char *what, const char *why)
{
    fprintf(stderr, "%s: %s: %s\n", bench, what, why);
    return 1;
}

/* The sim-vga board with its socket in dir, looking at scene_path (or dark when NULL); the
 * firmware starts serving in *th and *address gets "sim:<socket>". */
static int bench_start_board(const char *bench, wdr_board *b, const char *scene_path, const char *dir, char *address,
                             size_t cap, pthread_t *th)
{
    char path[512], err[512], sock[128];
    wdr_scene sc = {0};
    wdr_board_defaults(b);
    wdr_board_path("sim-vga", path, sizeof path);
    if (wdr_board_load(path, b, err, sizeof err) != WDR_OK)
        return bench_die(bench, "board", err);
    if (scene_path && wdr_scene_load(scene_path, b, &sc, err, sizeof err) != WDR_OK)
        return bench_die(bench, "scene", err);
    snprintf(sock, sizeof sock, "%s/board.sock", dir);
    snprintf(address, cap, "sim:%s", sock);
    hal_sim_config cfg = {.board = b, .seed = scene_path ? sc.chip_seed : 1, .frame_seed = sc.frame_seed,
                          .socket_path = sock};
    if (hal_sim_setup(&cfg, err, sizeof err) != WDR_OK)
        return bench_die(bench, "hal_sim_setup", err);
    if (scene_path) {
        wdr_scene_apply(&sc, hal_sim_sensor());
        wdr_scene_free(&sc);
    }
    if (hal_init() != WDR_OK || pthread_create(th, NULL, bench_serve, NULL) != 0)
        return bench_die(bench, "firmware", "did not start");
    return 0;
}

#endif
