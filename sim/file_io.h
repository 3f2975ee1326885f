/* Whole files into memory: board, scene and table files are small. */
#ifndef WDR_FILE_IO_H
#define WDR_FILE_IO_H
#include <stddef.h>
#include <stdint.h>

/* Read all of path into *buf (malloc'd, free(); one NUL byte past the end so text files are
 * strings); *len gets the size without that byte.
 * Only regular files: a directory, FIFO or device is refused (errno EISDIR or EINVAL).
 * @retval WDR_OK, WDR_E_IO (missing, unreadable or not a regular file), WDR_E_NOMEM */
int wdr_read_file(const char *path, uint8_t **buf, size_t *len);

/* The same for text: the string, or NULL when wdr_read_file fails. */
char *wdr_read_text(const char *path);

#endif
