/* Target images: the HDR readers (sim/hdr_image.c: OpenEXR, Radiance .hdr, PFM), told apart by
 * the first bytes as for a user's file. */
#include "fuzz_file.h"
#include "hdr_image.h"
#include <stdlib.h>
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
        volatile float sum = 0; /* every pixel the reader claims is there */
        for (size_t i = 0; i < (size_t)w * (size_t)h; i++)
            sum += lum[i];
    }
    free(lum);
    close(fd);
    return 0;
}
