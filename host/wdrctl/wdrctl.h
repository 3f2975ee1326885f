/* wdrctl: command table and helpers shared by the command files. */
#ifndef WDRCTL_H
#define WDRCTL_H
#include <sysexits.h>

typedef struct wdrctl_command {
    const char *group;   /* e.g. "lut", or NULL for a top-level command */
    const char *name;    /* e.g. "build" */
    int (*run)(int argc, char **argv); /* argv[0] is the command name; returns a sysexits code */
    const char *usage;
} wdrctl_command;

/* Commands, one per file group (cmd_*.c). */
int cmd_operators(int argc, char **argv);
int cmd_lut_build(int argc, char **argv);
int cmd_lut_plots(int argc, char **argv);

/* Print "wdrctl: " and a formatted message to stderr; returns code. */
int wdrctl_fail(int code, const char *fmt, ...) __attribute__((format(printf, 2, 3)));

/* Whether progress may be drawn (stderr is a terminal and CI is not set). */
int wdrctl_show_progress(void);

#endif
