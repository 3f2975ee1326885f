/* See wdrctl_child.h. */
#include "wdrctl_child.h"
#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <stdio.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

static double now_s(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + ts.tv_nsec / 1e9;
}

void wdr_child_slurp(const char *path, char *text, size_t cap)
{
    FILE *f = fopen(path, "r");
    size_t got = f ? fread(text, 1, cap - 1, f) : 0;
    text[got] = 0;
    if (f)
        fclose(f);
}

static void redirect(posix_spawn_file_actions_t *fa, int fd, const char *path)
{
    if (path)
        posix_spawn_file_actions_addopen(fa, fd, path, O_WRONLY | O_CREAT | O_TRUNC, 0644);
    else
        posix_spawn_file_actions_addopen(fa, fd, "/dev/null", O_WRONLY, 0);
}

/* Wait for pid, killing it once guard_s has passed since t0. */
static int reap(pid_t pid, double t0, double guard_s)
{
    int status = 0;
    while (waitpid(pid, &status, WNOHANG) == 0) {
        if (now_s() - t0 > guard_s) {
            kill(pid, SIGKILL);
            waitpid(pid, &status, 0);
            return WDR_CHILD_KILLED;
        }
        usleep(5000);
    }
    return WIFEXITED(status) ? WEXITSTATUS(status) : WDR_CHILD_SIGNALLED;
}

int wdr_child_run(const char *path, const char *const *args, const char *out_path, const char *err_path,
                  double guard_s, double *wall_s)
{
    char *argv[40] = {(char *)path};
    int n = 1;
    while (args[n - 1] && n < 39) {
        argv[n] = (char *)args[n - 1];
        n++;
    }
    argv[n] = NULL;
    char *envp[] = {"CI=1", "PATH=/usr/bin:/bin", NULL};
    posix_spawn_file_actions_t fa;
    posix_spawn_file_actions_init(&fa);
    redirect(&fa, 1, out_path);
    redirect(&fa, 2, err_path);
    pid_t pid;
    double t0 = now_s();
    int spawned = posix_spawn(&pid, path, &fa, NULL, argv, envp);
    posix_spawn_file_actions_destroy(&fa);
    int rc = spawned == 0 ? reap(pid, t0, guard_s) : WDR_CHILD_NO_SPAWN;
    *wall_s = now_s() - t0;
    return rc;
}
