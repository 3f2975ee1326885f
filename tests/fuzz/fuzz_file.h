/* The readers under test take paths: hand them the input as an anonymous in-memory file
 * (memfd, a regular file to fstat) named /proc/self/fd/N. No disk, nothing left behind. */
#ifndef FUZZ_FILE_H
#define FUZZ_FILE_H
#include <stddef.h>
#include <stdint.h>

/* Write data to a fresh memfd; path gets its name. Returns the fd (close it after), or -1. */
int fz_file(const uint8_t *data, size_t size, char *path, size_t cap);

#endif
