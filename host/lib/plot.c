#include "plot.h"
#include "wdr_err.h"
#include <dirent.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <unistd.h>

#ifndef WDR_GNUPLOT
#define WDR_GNUPLOT "gnuplot"
#endif

int wdr_gnuplot_run(const char *script, char *err, int errlen)
{
    const char *env = getenv("WDR_GNUPLOT"), *exe = env ? env : WDR_GNUPLOT; /* one read: it cannot change */
    char cmd[600];
    snprintf(cmd, sizeof cmd, "'%s' 2>&1", exe);
    if (access(exe, X_OK) != 0 && strchr(exe, '/')) {
        snprintf(err, (size_t)errlen, "gnuplot not found at %s (apt-get install gnuplot-nox)", exe);
        return WDR_E_UNSUPPORTED;
    }
    FILE *p = popen(cmd, "w");
    if (!p) {
        snprintf(err, (size_t)errlen, "cannot start gnuplot (%s)", exe);
        return WDR_E_UNSUPPORTED;
    }
    fputs(script, p);
    int status = pclose(p);
    if (status == -1 || !WIFEXITED(status) || WEXITSTATUS(status) != 0) {
        snprintf(err, (size_t)errlen, "gnuplot failed (exit status %d)", WIFEXITED(status) ? WEXITSTATUS(status) : -1);
        return WEXITSTATUS(status) == 127 ? WDR_E_UNSUPPORTED : WDR_E_IO;
    }
    return WDR_OK;
}

int wdr_plot_tmpdir(char *out, int outlen)
{
    const char *base = getenv("TMPDIR") ? getenv("TMPDIR") : "/tmp";
    snprintf(out, (size_t)outlen, "%s/wdrplot.XXXXXX", base);
    return mkdtemp(out) ? WDR_OK : WDR_E_IO;
}

void wdr_plot_tmpdir_remove(const char *dir)
{
    DIR *d = opendir(dir);
    if (!d)
        return;
    struct dirent *e;
    char path[1024];
    while ((e = readdir(d))) {
        if (!strcmp(e->d_name, ".") || !strcmp(e->d_name, ".."))
            continue;
        snprintf(path, sizeof path, "%s/%s", dir, e->d_name);
        unlink(path);
    }
    closedir(d);
    rmdir(dir);
}
