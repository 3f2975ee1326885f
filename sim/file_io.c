#include "file_io.h"
#include "wdr_err.h"
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <sys/stat.h>

/* Only regular files: a directory opens fine, then ftell says LONG_MAX and malloc(2^63)
 * follows; a FIFO or a device has no length to trust. */
static long regular_file_size(FILE *f)
{
    struct stat st;
    if (fstat(fileno(f), &st) != 0)
        return -1;
    if (!S_ISREG(st.st_mode)) {
        errno = S_ISDIR(st.st_mode) ? EISDIR : EINVAL; /* for the caller's message */
        return -1;
    }
    return fseek(f, 0, SEEK_END) == 0 ? ftell(f) : -1;
}

int wdr_read_file(const char *path, uint8_t **buf, size_t *len)
{
    *buf = NULL;
    *len = 0;
    FILE *f = fopen(path, "rb");
    if (!f)
        return WDR_E_IO;
    long n = regular_file_size(f);
    int rc = n >= 0 && fseek(f, 0, SEEK_SET) == 0 ? WDR_OK : WDR_E_IO;
    if (!rc && !(*buf = malloc((size_t)n + 1)))
        rc = WDR_E_NOMEM;
    if (!rc && fread(*buf, 1, (size_t)n, f) != (size_t)n)
        rc = WDR_E_IO;
    fclose(f);
    if (rc) {
        free(*buf);
        *buf = NULL;
        return rc;
    }
    (*buf)[n] = 0;
    *len = (size_t)n;
    return WDR_OK;
}

char *wdr_read_text(const char *path)
{
    uint8_t *buf;
    size_t len;
    return wdr_read_file(path, &buf, &len) == WDR_OK ? (char *)buf : NULL;
}
