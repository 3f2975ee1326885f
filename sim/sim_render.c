/* Exposure, row reads and whole frames, spread over threads by rows. Every pixel's result
 * depends only on the seeds and its index, so any thread count gives the same bits. */
#include "sim_internal.h"
#include "wdr_err.h"
#include <math.h>
#include <pthread.h>
#include <stdatomic.h>
#include <unistd.h>

#define ROWS_PER_GRAB 4

enum job_kind { JOB_EXPOSE, JOB_RENDER_U16, JOB_RENDER_FLOAT };

typedef struct render_job {
    wdr_sim *s;
    enum job_kind kind;
    void *out;
    atomic_int next_row, rows_done;
} render_job;

static const sim_ramp_table *active_table(const wdr_sim *s, const sim_plan *plan)
{
    return plan->on[WDR_FX_DAC_QUANT] ? &s->stepped : &s->continuous;
}

static void do_row(render_job *job, int row)
{
    wdr_sim *s = job->s;
    const sim_ramp_table *tab = active_table(s, &s->plan);
    long off = (long)row * s->width;
    if (job->kind == JOB_EXPOSE)
        sim_expose_row(s, &s->plan, tab, row, s->hold_v + off, s->hold_t + off);
    else if (job->kind == JOB_RENDER_FLOAT)
        sim_render_row(s, &s->plan, tab, row, row * s->board.row_time_s, (float *)job->out + off, NULL);
    else
        sim_render_row(s, &s->plan, tab, row, row * s->board.row_time_s, NULL, (uint16_t *)job->out + off);
}

/* Rows are taken a few at a time from a shared counter; only the caller's thread reports
 * progress, so the callback never runs concurrently with itself. */
static void work(render_job *job, int reports)
{
    wdr_sim *s = job->s;
    for (;;) {
        int row0 = atomic_fetch_add(&job->next_row, ROWS_PER_GRAB);
        if (row0 >= s->height)
            break;
        int row1 = row0 + ROWS_PER_GRAB < s->height ? row0 + ROWS_PER_GRAB : s->height;
        for (int r = row0; r < row1; r++)
            do_row(job, r);
        int done = atomic_fetch_add(&job->rows_done, row1 - row0) + row1 - row0;
        if (s->progress && reports && done < s->height)
            s->progress(s->progress_ctx, done, s->height);
    }
}

static void *worker(void *arg)
{
    work(arg, 0);
    return NULL;
}

static int thread_count(const wdr_sim *s)
{
    int n = s->threads;
    if (n <= 0) {
        long cores = sysconf(_SC_NPROCESSORS_ONLN);
        n = cores > 0 ? (int)cores : 1;
    }
    return n > 64 ? 64 : n;
}

static int run_job(wdr_sim *s, enum job_kind kind, void *out)
{
    render_job job = {.s = s, .kind = kind, .out = out};
    atomic_init(&job.next_row, 0);
    atomic_init(&job.rows_done, 0);
    pthread_t th[64];
    int n = thread_count(s), started = 0;
    for (; started < n - 1; started++)
        if (pthread_create(&th[started], NULL, worker, &job))
            break; /* fewer threads is still correct: the caller's thread takes the rest */
    work(&job, 1);
    for (int k = 0; k < started; k++)
        pthread_join(th[k], NULL);
    if (s->progress) /* the end, once, after every thread has finished */
        s->progress(s->progress_ctx, s->height, s->height);
    return WDR_OK;
}

static int begin_frame(wdr_sim *s, uint64_t frame_seed)
{
    if (!s->have_lut)
        return WDR_E_NO_TABLE;
    s->frame_seed = frame_seed;
    if (s->plan_stale) /* the plan does not depend on the frame seed: frames of one scene share it */
        sim_plan_effects(s, &s->plan);
    s->plan_stale = 0;
    return WDR_OK;
}

int wdr_sim_expose(wdr_sim *s, uint64_t frame_seed)
{
    int rc = begin_frame(s, frame_seed);
    if (rc)
        return rc;
    rc = run_job(s, JOB_EXPOSE, NULL);
    s->exposed = rc == WDR_OK;
    return rc;
}

int wdr_sim_read_row(wdr_sim *s, int row, double t_after_s, uint16_t *codes)
{
    if (!s->exposed || row < 0 || row >= s->height || !(t_after_s >= 0) || !isfinite(t_after_s))
        return WDR_E_INVAL;
    const sim_ramp_table *tab = active_table(s, &s->plan);
    long off = (long)row * s->width;
    sim_read_row(s, &s->plan, tab->t_int, row, s->hold_v + off, s->hold_t + off, t_after_s, NULL, codes);
    return WDR_OK;
}

int wdr_sim_render(wdr_sim *s, uint64_t frame_seed, uint16_t *frame)
{
    int rc = begin_frame(s, frame_seed);
    return rc ? rc : run_job(s, JOB_RENDER_U16, frame);
}

int wdr_sim_render_float(wdr_sim *s, uint64_t frame_seed, float *frame)
{
    int rc = begin_frame(s, frame_seed);
    return rc ? rc : run_job(s, JOB_RENDER_FLOAT, frame);
}

const wdr_fx_report *wdr_sim_report(const wdr_sim *s) { return s->report; }

double wdr_sim_integration_time(const wdr_sim *s) { return s->have_lut ? s->stepped.t_int : 0.0; }
