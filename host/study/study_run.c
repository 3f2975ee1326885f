/* Every point of a study on worker processes (one per job), each sending its results back over
 * a pipe; the parent shows progress. Processes, not threads: the calibration library keeps no
 * promise of thread safety, and a point that crashes takes only its worker down. */
#include "study.h"
#include <errno.h>
#include <poll.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <sysexits.h>
#include <time.h>
#include <unistd.h>

#define MAX_JOBS 64

typedef struct msg {
    int index;
    study_result r;
} msg;

static double now_s(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

static int write_full(int fd, const void *buf, size_t n)
{
    for (const char *p = buf; n;) {
        ssize_t w = write(fd, p, n);
        if (w < 0 && errno == EINTR)
            continue;
        if (w <= 0)
            return -1;
        p += w, n -= (size_t)w;
    }
    return 0;
}

/* 1: a whole message, 0: end of stream, -1: error or a torn message */
static int read_full(int fd, void *buf, size_t n)
{
    size_t got = 0;
    while (got < n) {
        ssize_t r = read(fd, (char *)buf + got, n - got);
        if (r < 0 && errno == EINTR)
            continue;
        if (r <= 0)
            return got == 0 && r == 0 ? 0 : -1;
        got += (size_t)r;
    }
    return 1;
}

static void worker(const study *s, int w, int jobs, int fd)
{
    for (int i = w; i < s->n; i += jobs) {
        msg m = {.index = i};
        study_eval_point(s, &s->pts[i], &m.r);
        if (write_full(fd, &m, sizeof m))
            _exit(EX_IOERR);
    }
    _exit(EX_OK);
}

static void progress(int done, int n, double t0, int show)
{
    double t = now_s() - t0, left = done ? t / done * (n - done) : 0;
    if (show)
        fprintf(stderr, "\rstudy: %d/%d points, %.0f s, about %.0f s left   %s", done, n, t, left,
                done == n ? "\n" : "");
    else if (done == n || (done * 20 / n) != ((done - 1) * 20 / n)) /* a line every 5 % in logs */
        fprintf(stderr, "study: %d/%d points, %.0f s\n", done, n, t);
}

static int collect(study *s, struct pollfd *fds, int jobs, double t0, int show)
{
    int done = 0, open = jobs;
    while (open) {
        if (poll(fds, (nfds_t)jobs, -1) < 0) {
            if (errno == EINTR)
                continue;
            return study_fail(EX_OSERR, "poll: %s", strerror(errno));
        }
        for (int w = 0; w < jobs; w++) {
            if (fds[w].fd < 0 || !(fds[w].revents & (POLLIN | POLLHUP)))
                continue;
            msg m;
            int rc = read_full(fds[w].fd, &m, sizeof m);
            if (rc == 1 && m.index >= 0 && m.index < s->n) {
                s->res[m.index] = m.r;
                progress(++done, s->n, t0, show);
                continue;
            }
            close(fds[w].fd), fds[w].fd = -1, open--;
        }
    }
    return done == s->n ? EX_OK
                        : study_fail(EX_SOFTWARE, "only %d of %d points came back from the workers", done, s->n);
}

int study_run(study *s, int show_progress, double *wall_s)
{
    int jobs = s->jobs < 1 ? 1 : s->jobs > MAX_JOBS ? MAX_JOBS : s->jobs;
    jobs = jobs > s->n ? s->n : jobs;
    pid_t pid[MAX_JOBS];
    struct pollfd fds[MAX_JOBS];
    double t0 = now_s();
    s->res = calloc((size_t)s->n, sizeof *s->res);
    if (!s->res)
        return study_fail(EX_OSERR, "out of memory");
    fflush(NULL);
    for (int w = 0; w < jobs; w++) {
        int p[2];
        if (pipe(p) || (pid[w] = fork()) < 0)
            return study_fail(EX_OSERR, "cannot start worker %d: %s", w, strerror(errno));
        if (pid[w] == 0) {
            close(p[0]);
            for (int k = 0; k < w; k++)
                close(fds[k].fd);
            worker(s, w, jobs, p[1]);
        }
        close(p[1]);
        fds[w] = (struct pollfd){.fd = p[0], .events = POLLIN};
    }
    int rc = collect(s, fds, jobs, t0, show_progress);
    for (int w = 0; w < jobs; w++) {
        int st;
        if (waitpid(pid[w], &st, 0) < 0 || !WIFEXITED(st) || WEXITSTATUS(st) != EX_OK)
            rc = rc != EX_OK ? rc : study_fail(EX_SOFTWARE, "worker %d failed (status %d)", w, st);
    }
    *wall_s = now_s() - t0;
    return rc;
}
