#include "file_io.h"
#include "wdr_err.h"
#include <stdio.h>
#include <stdlib.h>

int wdr_read_file(const char *path, uint8_t **buf, size_t *len)
{
    *buf = NULL;
    *len = 0;
    FILE *f = fopen(path, "rb");
    if (!f)
        return WDR_E_IO;
    long n = fseek(f, 0, SEEK_END) == 0 ? ftell(f) : -1;
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
