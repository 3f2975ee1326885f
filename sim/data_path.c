/* Board and scene files by name (see data_path.h). */
#include "data_path.h"
#include <dirent.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#ifndef WDR_DATA_FROM_BIN
#define WDR_DATA_FROM_BIN "../share/wdrcam" /* the install's DATADIR/wdrcam relative to its BINDIR */
#endif
#define SEARCH_UP 3     /* folders above the program's tried too: tests live deeper in the build tree */
#define MAX_NAMES 64

static const char *const env_of[] = {"WDR_BOARDS_DIR", "WDR_SCENES_DIR"};
static const char *const sub_of[] = {"boards", "scenes"};
static const char *const what_of[] = {"board", "scene"};

static int is_dir(const char *path)
{
    struct stat st;
    return stat(path, &st) == 0 && S_ISDIR(st.st_mode);
}

/* The running program's folder, from /proc/self/exe. */
static int program_dir(char *out, size_t outlen)
{
    ssize_t n = readlink("/proc/self/exe", out, outlen - 1);
    if (n <= 0)
        return 0;
    out[n] = 0;
    char *slash = strrchr(out, '/');
    if (!slash)
        return 0;
    *slash = 0;
    return 1;
}

void wdr_data_dir(wdr_data_kind k, char *out, int outlen)
{
    const char *env = getenv(env_of[k]);
    char dir[4096], cand[4200];
    out[0] = 0;
    if (env && *env) {
        snprintf(out, (size_t)outlen, "%s", env);
        return;
    }
    if (!program_dir(dir, sizeof dir))
        return;
    for (int up = 0; up <= SEARCH_UP; up++) {
        snprintf(cand, sizeof cand, "%s/%s/%s", dir, WDR_DATA_FROM_BIN, sub_of[k]);
        char real[4096];
        if (is_dir(cand) && realpath(cand, real)) { /* without the ../ steps, as a reader expects */
            snprintf(out, (size_t)outlen, "%s", real);
            return;
        }
        char *slash = strrchr(dir, '/');
        if (!slash || slash == dir)
            return;
        *slash = 0;
    }
}

int wdr_data_is_name(const char *text)
{
    size_t n = strlen(text);
    return n && !strchr(text, '/') && !(n >= 5 && !strcmp(text + n - 5, ".json"));
}

void wdr_data_path(wdr_data_kind k, const char *name, char *out, int outlen)
{
    char dir[4096];
    if (!wdr_data_is_name(name)) {
        snprintf(out, (size_t)outlen, "%s", name);
        return;
    }
    wdr_data_dir(k, dir, sizeof dir);
    if (k == WDR_DATA_BOARDS)
        snprintf(out, (size_t)outlen, "%s/%s/board.json", dir[0] ? dir : ".", name);
    else
        snprintf(out, (size_t)outlen, "%s/%s.json", dir[0] ? dir : ".", name);
}

/* The name an entry of the folder gives, or 0 when it is not one of kind k. */
static int entry_name(wdr_data_kind k, const char *dir, const char *entry, char *name, size_t len)
{
    char path[4400];
    struct stat st;
    size_t n = strlen(entry);
    if (entry[0] == '.')
        return 0;
    if (k == WDR_DATA_BOARDS) {
        snprintf(path, sizeof path, "%s/%s/board.json", dir, entry);
        if (stat(path, &st) || !S_ISREG(st.st_mode))
            return 0;
        snprintf(name, len, "%s", entry);
        return 1;
    }
    if (n < 6 || strcmp(entry + n - 5, ".json"))
        return 0;
    snprintf(name, len, "%.*s", (int)(n - 5), entry);
    return 1;
}

static int by_text(const void *a, const void *b) { return strcmp(*(char *const *)a, *(char *const *)b); }

void wdr_data_names(wdr_data_kind k, const char *sep, char *out, int outlen)
{
    char dir[4096], name[256], *names[MAX_NAMES];
    int n = 0;
    out[0] = 0;
    wdr_data_dir(k, dir, sizeof dir);
    DIR *d = dir[0] ? opendir(dir) : NULL;
    for (struct dirent *e; d && (e = readdir(d)) && n < MAX_NAMES;)
        if (entry_name(k, dir, e->d_name, name, sizeof name) && (names[n] = strdup(name)))
            n++;
    if (d)
        closedir(d);
    qsort(names, (size_t)n, sizeof *names, by_text);
    size_t used = 0;
    for (int i = 0; i < n; i++) {
        int w = snprintf(out + used, (size_t)outlen - used, "%s%s", i ? sep : "", names[i]);
        used = w > 0 && used + (size_t)w < (size_t)outlen ? used + (size_t)w : used;
        free(names[i]);
    }
}

void wdr_data_unknown(wdr_data_kind k, const char *name, char *out, int outlen)
{
    char dir[4096], names[2048];
    const char *env = getenv(env_of[k]); /* one read: it cannot change between the tests */
    int from_env = env && *env;
    wdr_data_dir(k, dir, sizeof dir);
    wdr_data_names(k, ", ", names, sizeof names);
    if (!dir[0])
        snprintf(out, (size_t)outlen, "unknown %s '%s': no %s folder found (set %s, or give a file path)",
                 what_of[k], name, sub_of[k], env_of[k]);
    else
        snprintf(out, (size_t)outlen, "unknown %s '%s' (known: %s; in %s%s%s)", what_of[k], name,
                 names[0] ? names : "none", dir, from_env ? ", set by " : "", from_env ? env_of[k] : "");
}

int wdr_data_print_names(FILE *f, const char *kind)
{
    char names[4096];
    int k = !strcmp(kind, "boards") ? WDR_DATA_BOARDS : !strcmp(kind, "scenes") ? WDR_DATA_SCENES : -1;
    if (k < 0)
        return 0;
    wdr_data_names((wdr_data_kind)k, "\n", names, sizeof names);
    if (names[0])
        fprintf(f, "%s\n", names);
    return 1;
}
