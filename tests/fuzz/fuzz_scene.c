/* Target scene: the scene JSON loader (sim/scene.c) for a small board, every field and its map
 * at the board's size. */
#include "board.h"
#include "fuzz_file.h"
#include "wdr_err.h"
#include "wdr_scene.h"
#include <unistd.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static wdr_board b;
    static int ready;
    if (!ready) {
        wdr_board_defaults(&b);
        b.width = 32;
        b.height = 24;
        ready = 1;
    }
    char path[64], err[512];
    int fd = fz_file(data, size, path, sizeof path);
    if (fd < 0)
        return 0;
    wdr_scene sc;
    if (wdr_scene_load(path, &b, &sc, err, sizeof err) == WDR_OK)
        wdr_scene_free(&sc);
    close(fd);
    return 0;
}
