/* gnuplot, fed a script on stdin (see plot.h). */
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

/* The first lines of gnuplot's captured messages, on one line, into err. */
static void tell_messages(FILE *log, char *err, int errlen)
{
    size_t used = strlen(err);
    char line[256];
    rewind(log);
    for (int k = 0; k < 4 && fgets(line, sizeof line, log); k++) {
        line[strcspn(line, "\n")] = 0;
        if (!line[0])
            continue;
        int n = snprintf(err + used, (size_t)errlen - used, "%s%s", k ? " / " : ": ", line);
        used = n > 0 && used + (size_t)n < (size_t)errlen ? used + (size_t)n : used;
    }
}

int wdr_gnuplot_run(const char *script, char *err, int errlen)
{
    const char *env = getenv("WDR_GNUPLOT"), *exe = env ? env : WDR_GNUPLOT; /* one read: it cannot change */
    char cmd[700], log_path[] = "/tmp/wdrgnuplot.XXXXXX";
    if (access(exe, X_OK) != 0 && strchr(exe, '/')) {
        snprintf(err, (size_t)errlen, "gnuplot not found at %s (apt-get install gnuplot-nox)", exe);
        return WDR_E_UNSUPPORTED;
    }
    int log_fd = mkstemp(log_path);
    FILE *log = log_fd >= 0 ? fdopen(log_fd, "w+") : NULL;
    if (!log) {
        snprintf(err, (size_t)errlen, "cannot capture gnuplot's messages (%s)", log_path);
        return WDR_E_IO;
    }
    /* stdout too: with no output file gnuplot would write the PNG itself to the terminal */
    snprintf(cmd, sizeof cmd, "'%s' >/dev/null 2>'%s'", exe, log_path);
    FILE *p = popen(cmd, "w");
    if (!p) {
        fclose(log);
        unlink(log_path);
        snprintf(err, (size_t)errlen, "cannot start gnuplot (%s)", exe);
        return WDR_E_UNSUPPORTED;
    }
    fputs(script, p);
    int status = pclose(p);
    int rc = WDR_OK;
    if (status == -1 || !WIFEXITED(status) || WEXITSTATUS(status) != 0) {
        snprintf(err, (size_t)errlen, "gnuplot failed (exit status %d)", WIFEXITED(status) ? WEXITSTATUS(status) : -1);
        tell_messages(log, err, errlen);
        rc = WIFEXITED(status) && WEXITSTATUS(status) == 127 ? WDR_E_UNSUPPORTED : WDR_E_IO;
    }
    fclose(log);
    unlink(log_path);
    return rc;
}

/* ---- Series styles ------------------------------------------------------------------------ */

static const struct series_style {
    const char *colour;
    int dash, point;
} styles[] = {{"#1f77b4", 1, 7}, {"#d62728", 2, 5},  {"#2ca02c", 3, 9},  {"#9467bd", 4, 13},
              {"#ff7f0e", 5, 15}, {"#8c564b", 1, 4}, {"#e377c2", 2, 6},  {"#17becf", 3, 8},
              {"#7f7f7f", 4, 12}, {"#bcbd22", 5, 14}, {"#000000", 1, 1}, {"#aec7e8", 2, 2}};
#define N_STYLES ((int)(sizeof styles / sizeof *styles))

static const struct series_style *style_of(int k) { return &styles[((k % N_STYLES) + N_STYLES) % N_STYLES]; }

const char *wdr_plot_style(int k)
{
    static char text[N_STYLES][48];
    const struct series_style *s = style_of(k);
    char *t = text[s - styles];
    snprintf(t, sizeof text[0], "lc rgb '%s' dt %d pt %d", s->colour, s->dash, s->point);
    return t;
}

int wdr_plot_floored_series(char *script, size_t cap, const char *data, int col, int k, const char *title,
                            double floor)
{
    const struct series_style *s = style_of(k);
    return snprintf(script, cap,
                    ", '%s' u 1:(column(%d) < %g ? %g : column(%d)) w l lw 1.5 lc rgb '%s' dt %d notitle"
                    ", '%s' u 1:(column(%d) < %g ? NaN : column(%d)) w lp lw 1.5 lc rgb '%s' dt %d pt %d t '%s'"
                    ", '%s' u 1:(column(%d) < %g ? %g : NaN) w p lc rgb '%s' pt 11 ps 1.5 notitle",
                    data, col, floor, floor, col, s->colour, s->dash, data, col, floor, col, s->colour, s->dash,
                    s->point, title, data, col, floor, floor, s->colour);
}

int wdr_plot_floor_key(char *script, size_t cap, double floor, const char *unit)
{
    return snprintf(script, cap, ", NaN w p pt 11 ps 1.4 lc rgb 'black' t 'below %g%s%s: drawn at the floor'", floor,
                    unit[0] ? " " : "", unit);
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
