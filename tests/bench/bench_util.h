/* Shared by the benchmark programs: a monotonic clock. */
#ifndef BENCH_UTIL_H
#define BENCH_UTIL_H
#include <time.h>

static inline double now_s(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + (double)ts.tv_nsec * 1e-9;
}

#endif
