/* Target images: the HDR readers (sim/hdr_image.c: OpenEXR, Radiance .hdr, PFM), told apart by
 * the first bytes as for a user's file. */
#include "fuzz_file.h"
#include "hdr_image.h"
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    char path[64], err[512];
    int fd = fz_file(data, size, path, sizeof path);
    if (fd < 0)
        return 0;
    float *lum = NULL;
    int w, h;
    if (wdr_hdr_load(path, &lum, &w, &h, err, sizeof err) == 0) {
        if (w < 1 || h < 1)
            abort(); /* a loaded image has pixels */
        float *copy = malloc((size_t)w * (size_t)h * sizeof *copy); /* every pixel it claims is there */
        memcpy(copy, lum, (size_t)w * (size_t)h * sizeof *copy);
        free(copy);
    }
    free(lum);
    close(fd);
    return 0;
}
