/* Studies across machines: a shard computes every N-th point of the full expansion (points
 * K-1, K-1+N, ...) into a shard file; the merge reads all N shard files back into one study, in
 * the full study's order, for the fronts, the plots and the answers. The scheduling is the
 * cluster's (GNU parallel, a Slurm array job: README.md), never ours.
 *
 * Shard file (binary, this build's struct layout, checked on reading): "WSHD", u32 version 1,
 * u32 K, u32 N, u32 points of the full study, u32 sizeof(study_point), u32 sizeof(study_result),
 * then range_lo, range_hi, fps (f64), seed (u64), board name (256 bytes, NUL padded), wall
 * seconds (f64), u32 count, then count x {u32 index, study_point, study_result}. Machines that
 * share the build (same compiler, same architecture) read each other's shards; another layout is
 * refused by its sizes. */
#include "study.h"
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sysexits.h>

#define SHARD_MAGIC "WSHD"
#define SHARD_VERSION 1u
#define BOARD_BYTES 256

typedef struct shard_head {
    char magic[4];
    uint32_t version, k, n, points, point_size, result_size;
    double range_lo, range_hi, fps;
    uint64_t seed;
    char board[BOARD_BYTES];
    double wall_s;
    uint32_t count;
} shard_head;

static int fail(int code, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    fprintf(stderr, "wdrctl: study: ");
    vfprintf(stderr, fmt, ap);
    fprintf(stderr, "\n");
    va_end(ap);
    return code;
}

int study_shard_parse(const char *text, int *k, int *n)
{
    char *e;
    long a = strtol(text, &e, 10), b = *e == '/' ? strtol(e + 1, &e, 10) : 0;
    if (*e || b < 1 || b > STUDY_MAX_POINTS || a < 1 || a > b)
        return fail(EX_USAGE, "--shard '%s' must be K/N with 1 <= K <= N <= %d", text, STUDY_MAX_POINTS);
    *k = (int)a, *n = (int)b;
    return EX_OK;
}

void study_shard_select(study *s, int k, int n)
{
    int m = 0;
    for (int i = 0; i < s->n; i++)
        if (i % n == k - 1)
            s->pts[m] = s->pts[i], s->index[m++] = i;
    s->full_n = s->n;
    s->n = m;
}

int study_shard_write(const study *s, int k, int n, const char *path, double wall_s)
{
    shard_head h = {.version = SHARD_VERSION,
                    .k = (uint32_t)k,
                    .n = (uint32_t)n,
                    .points = (uint32_t)s->full_n,
                    .point_size = sizeof(study_point),
                    .result_size = sizeof(study_result),
                    .range_lo = s->range_lo,
                    .range_hi = s->range_hi,
                    .fps = s->fps,
                    .seed = s->seed,
                    .wall_s = wall_s,
                    .count = (uint32_t)s->n};
    memcpy(h.magic, SHARD_MAGIC, 4);
    snprintf(h.board, sizeof h.board, "%s", s->board);
    FILE *f = fopen(path, "wb");
    int ok = f && fwrite(&h, sizeof h, 1, f) == 1;
    for (int i = 0; ok && i < s->n; i++) {
        uint32_t idx = (uint32_t)s->index[i];
        ok = fwrite(&idx, sizeof idx, 1, f) == 1 && fwrite(&s->pts[i], sizeof s->pts[i], 1, f) == 1 &&
             fwrite(&s->res[i], sizeof s->res[i], 1, f) == 1;
    }
    if (f && fclose(f))
        ok = 0;
    return ok ? EX_OK : fail(EX_CANTCREAT, "%s: cannot write the shard file", path);
}

static int same_study(const shard_head *a, const shard_head *b)
{
    return a->n == b->n && a->points == b->points && a->range_lo == b->range_lo && a->range_hi == b->range_hi &&
           a->fps == b->fps && a->seed == b->seed && !strcmp(a->board, b->board);
}

/* One shard's points into s (allocated for the full study by the first shard). */
static int read_one(const char *path, study *s, shard_head *first, int *seen, double *wall)
{
    shard_head h;
    FILE *f = fopen(path, "rb");
    if (!f)
        return fail(EX_NOINPUT, "%s: cannot read the shard file", path);
    int rc = EX_OK;
    if (fread(&h, sizeof h, 1, f) != 1 || memcmp(h.magic, SHARD_MAGIC, 4) || h.version != SHARD_VERSION)
        rc = fail(EX_DATAERR, "%s: not a study shard file (magic, version)", path);
    else if (h.point_size != sizeof(study_point) || h.result_size != sizeof(study_result))
        rc = fail(EX_DATAERR, "%s: written by another build (point %u, result %u bytes)", path, h.point_size,
                  h.result_size);
    else if (h.points == 0 || h.points > STUDY_MAX_POINTS || h.n == 0 || h.k == 0 || h.k > h.n || h.count > h.points)
        rc = fail(EX_DATAERR, "%s: field 'shard' %u/%u out of range", path, h.k, h.n);
    else if (first->version && !same_study(first, &h))
        rc = fail(EX_DATAERR, "%s: another study (board, range, fps, seed or shard count differ), shard %u/%u", path,
                  h.k, h.n);
    else if (first->version && seen[h.k - 1])
        rc = fail(EX_DATAERR, "%s: shard %u/%u given twice", path, h.k, h.n);
    if (rc == EX_OK && !first->version) {
        *first = h;
        s->full_n = s->n = (int)h.points;
        s->pts = calloc(h.points, sizeof *s->pts), s->res = calloc(h.points, sizeof *s->res);
        s->index = NULL;
        if (!s->pts || !s->res)
            rc = fail(EX_OSERR, "%s: out of memory", path);
    }
    for (uint32_t i = 0; rc == EX_OK && i < h.count; i++) {
        uint32_t idx;
        study_point p;
        study_result r;
        if (fread(&idx, sizeof idx, 1, f) != 1 || fread(&p, sizeof p, 1, f) != 1 || fread(&r, sizeof r, 1, f) != 1)
            rc = fail(EX_DATAERR, "%s: truncated after %u of %u points", path, i, h.count);
        else if (idx >= h.points || idx % h.n != h.k - 1)
            rc = fail(EX_DATAERR, "%s: field 'index' %u is not shard %u's", path, idx, h.k);
        else
            s->pts[idx] = p, s->res[idx] = r;
    }
    if (rc == EX_OK)
        seen[h.k - 1] = 1, *wall += h.wall_s;
    fclose(f);
    return rc;
}

int study_shard_merge(char **paths, int n_paths, study *s, char *board, int board_len, double *wall_s)
{
    static int seen[STUDY_MAX_POINTS];
    shard_head first = {0};
    memset(seen, 0, sizeof seen);
    *wall_s = 0;
    int rc = EX_OK;
    for (int i = 0; rc == EX_OK && i < n_paths; i++)
        rc = read_one(paths[i], s, &first, seen, wall_s);
    if (rc == EX_OK && !n_paths)
        rc = fail(EX_USAGE, "--merge needs the shard files");
    for (uint32_t k = 0; rc == EX_OK && k < first.n; k++)
        if (!seen[k])
            rc = fail(EX_DATAERR, "shard %u/%u missing: every shard of the study is needed (%d files given)", k + 1,
                      first.n, n_paths);
    if (rc == EX_OK) {
        snprintf(board, (size_t)board_len, "%s", first.board);
        s->board = board, s->range_lo = first.range_lo, s->range_hi = first.range_hi, s->fps = first.fps;
        s->seed = first.seed;
    }
    return rc;
}
