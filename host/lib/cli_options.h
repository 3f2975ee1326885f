/* Declarative command lines: one table of options per command, from which come the parser,
 * `--help`, `help CMD`, the man page and the bash completion. Every program uses it (wdrctl,
 * wdrsim, wdr-simboard, wdr-board); numbers go through cli_number.h. Depends on libc only.
 *
 * A command's options are a table of rows ending with an all-zero row; a row names the field
 * of the command's own options struct it fills:
 *
 *   #define O(f) offsetof(lut_opts, f)
 *   static const cli_option rows[] = {
 *       {"operator", 0, CLI_STRING, O(op_name), "NAME", "tone-mapping operator", .flags = CLI_REQUIRED},
 *       {"entries", 0, CLI_INT, O(entries), "N", "entries of the table", .min = 1, .max = 65536},
 *       {0}};
 *
 * Errors are printed ("wdrctl: lut build: option --entries: '0' is out of range 1..65536") and
 * returned as sysexits codes (EX_USAGE). */
#ifndef CLI_OPTIONS_H
#define CLI_OPTIONS_H
#include <stddef.h>
#include <stdio.h>

typedef enum cli_kind {
    CLI_FLAG,   /* no value: sets an int to 1 */
    CLI_STRING, /* const char *: the text as given */
    CLI_INT,    /* int in [min, max] */
    CLI_U64,    /* uint64_t in [min, max]; max 0 means no upper bound */
    CLI_DOUBLE, /* double in [min, max] (both 0: any finite number) */
    CLI_CHOICE, /* int: the value of the choice named */
    CLI_LIST,   /* repeatable: const char *[max], with the count in the int at .count */
} cli_kind;

enum cli_option_flags {
    CLI_REQUIRED = 1 << 0, /* the command refuses to run without it */
    CLI_HIDDEN = 1 << 1,   /* accepted (an old spelling) but not listed */
};

typedef struct cli_choice {
    const char *name;
    int value;
} cli_choice;

typedef struct cli_option {
    const char *name;          /* long name without "--" */
    char short_name;           /* -X, or 0 */
    cli_kind kind;
    size_t offset;             /* offsetof the field it fills */
    const char *metavar;       /* the value in help ("FILE"); NULL for flags */
    const char *help;          /* one line */
    double min, max;           /* CLI_INT, CLI_U64, CLI_DOUBLE: inclusive range; CLI_LIST: max entries */
    const cli_choice *choices; /* CLI_CHOICE: ends with a NULL name */
    const char *what;          /* CLI_CHOICE: what a choice is in messages ("table form") */
    size_t count;              /* CLI_LIST: offsetof its int count */
    size_t given;              /* CLI_GIVEN(type, field): an int set to 1 when the option is given */
    unsigned flags;            /* enum cli_option_flags */
    const char *values;        /* completion of the value: words ("a b c"), or "@KIND" for the names
                                * the program lists at completion time (PROG --values KIND), with
                                * file names too when the metavar says FILE ("NAME|FILE") */
} cli_option;

#define CLI_GIVEN(type, field) (offsetof(type, field) + 1)

enum cli_command_flags {
    CLI_CMD_BOARD = 1 << 0, /* talks to a board: takes the program's global options */
};

typedef struct cli_command {
    const char *name;          /* "lut build"; NULL for the only command of a program */
    const char *args;          /* positional arguments in the synopsis ("LUT.bin"), or NULL */
    int min_args, max_args;
    const char *summary;       /* one line */
    const char *details;       /* a paragraph for --help and the man page, or NULL */
    const cli_option *options; /* ends with an all-zero row */
    int (*run)(int argc, char **argv); /* argv[0] is the command's name; a sysexits code */
    unsigned flags;            /* enum cli_command_flags */
} cli_command;

typedef struct cli_section {
    const char *title, *text; /* a man page section: ENVIRONMENT, EXIT STATUS, FILES, EXAMPLES */
} cli_section;

typedef struct cli_program {
    const char *name, *summary, *description;
    const cli_option *globals;          /* options valid before or after any board command */
    size_t globals_size;                /* sizeof the struct globals fill (0: none) */
    const cli_command *const *commands; /* NULL-terminated; NULL: the program is `single` */
    const cli_command *single;          /* the one command of a program without commands */
    const cli_section *sections;        /* ends with a NULL title; may be NULL */
    /* The values of an "@KIND" completion, one per line (boards, scenes, operators); NULL: none */
    void (*print_values)(FILE *f, const char *kind);
} cli_program;

/* Parse argv[1..argc-1] by cmd's table into opts (defaults already set). Positional arguments
 * are moved, in order, to argv[1..*n_args]; their count must be in min_args..max_args. `--`
 * ends the options. @return EX_OK or EX_USAGE (printed, prefixed "PROG: CMD: ") */
int cli_parse(const cli_program *p, const cli_command *cmd, int argc, char **argv, void *opts, int *n_args);

/* The whole command line of a program with commands: global options before the command,
 * --help, --version, --man, --bash-completion, --values KIND, `help [CMD]`, then the command with its global
 * options (before or after it) parsed into globals and taken out of its argv.
 * @return the command's exit code, or EX_USAGE */
int cli_main(const cli_program *p, int argc, char **argv, void *globals);

/* A program without commands: --help, --version, --man, --bash-completion, --values KIND,
 * else cli_parse.
 * *done is set when the request was answered (help, version): exit with the code returned. */
int cli_main_single(const cli_program *p, int argc, char **argv, void *opts, int *n_args, int *done);

/* Help: the program's (every command, one line each) and one command's (every option). */
void cli_print_program_help(FILE *f, const cli_program *p);
void cli_print_command_help(FILE *f, const cli_program *p, const cli_command *cmd);
/* A man page (troff, section 1) and a bash completion script, both from the same tables. */
void cli_print_man(FILE *f, const cli_program *p);
void cli_print_bash_completion(FILE *f, const cli_program *p);
/* "PROG VERSION" and the protocol and table format versions of firmware/ (cli_version.c). */
void cli_print_version(FILE *f, const char *prog);

/* Shared with cli_help.c: whether a row takes a value; the command named by argv words. */
int cli_takes_value(const cli_option *o);
const cli_command *cli_find_command(const cli_program *p, int argc, char **argv, int *words);

#endif
