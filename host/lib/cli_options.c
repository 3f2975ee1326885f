/* Declarative command lines: parsing and dispatch (see cli_options.h; help, man page and
 * completion are in cli_help.c). */
#include "cli_options.h"
#include "cli_number.h"
#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <string.h>
#include <sysexits.h>

/* ---- messages ---- */

static int usage_error(const cli_program *p, const cli_command *cmd, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));

static int usage_error(const cli_program *p, const cli_command *cmd, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    fprintf(stderr, "%s: ", p->name);
    if (cmd && cmd->name)
        fprintf(stderr, "%s: ", cmd->name);
    vfprintf(stderr, fmt, ap);
    if (cmd && cmd->name)
        fprintf(stderr, " (see '%s %s --help')\n", p->name, cmd->name);
    else
        fprintf(stderr, " (see '%s --help')\n", p->name);
    va_end(ap);
    return EX_USAGE;
}

/* ---- one option ---- */

int cli_takes_value(const cli_option *o) { return o->kind != CLI_FLAG; }

static void *field(void *base, size_t offset) { return (char *)base + offset; }

static int set_number(const cli_program *p, const cli_command *cmd, const cli_option *o, const char *what,
                      const char *text, void *dest)
{
    char msg[320];
    int rc;
    double lo = o->min, hi = o->max;
    if (o->kind == CLI_INT) {
        long long v = 0;
        if ((rc = cli_number_long(text, (long long)lo, (long long)hi, &v)) == CLI_NUM_OK)
            *(int *)dest = (int)v;
    } else if (o->kind == CLI_U64) {
        hi = hi > 0 ? hi : 18446744073709551615.0;
        uint64_t v = 0, top = o->max > 0 ? (uint64_t)o->max : UINT64_MAX;
        if ((rc = cli_number_u64(text, (uint64_t)lo, top, &v)) == CLI_NUM_OK)
            *(uint64_t *)dest = v;
    } else {
        double v = 0;
        int any = lo == 0 && hi == 0;
        if ((rc = cli_number_double(text, any ? -HUGE_VAL : lo, any ? HUGE_VAL : hi, &v)) == CLI_NUM_OK)
            *(double *)dest = v;
    }
    if (rc == CLI_NUM_OK)
        return EX_OK;
    cli_number_message(rc, what, text, lo, hi, o->kind != CLI_DOUBLE, msg, sizeof msg);
    return usage_error(p, cmd, "%s", msg);
}

static int set_choice(const cli_program *p, const cli_command *cmd, const cli_option *o, const char *what,
                      const char *text, int *dest)
{
    char known[256] = "";
    for (const cli_choice *c = o->choices; c->name; c++) {
        if (!strcmp(c->name, text))
            return *dest = c->value, EX_OK;
        snprintf(known + strlen(known), sizeof known - strlen(known), "%s%s", c == o->choices ? "" : ", ", c->name);
    }
    return usage_error(p, cmd, "%s: unknown %s '%s' (known: %s)", what, o->what ? o->what : "value", text, known);
}

static int set_value(const cli_program *p, const cli_command *cmd, const cli_option *o, const char *text, void *opts)
{
    char what[96];
    snprintf(what, sizeof what, "option --%s", o->name);
    void *dest = field(opts, o->offset);
    if (o->given)
        *(int *)field(opts, o->given - 1) = 1;
    switch (o->kind) {
    case CLI_FLAG: *(int *)dest = 1; return EX_OK;
    case CLI_STRING: *(const char **)dest = text; return EX_OK;
    case CLI_CHOICE: return set_choice(p, cmd, o, what, text, dest);
    case CLI_LIST: {
        int *n = field(opts, o->count);
        if (*n >= (int)o->max)
            return usage_error(p, cmd, "too many --%s options (at most %d)", o->name, (int)o->max);
        ((const char **)dest)[(*n)++] = text;
        return EX_OK;
    }
    default: return set_number(p, cmd, o, what, text, dest);
    }
}

/* ---- finding a row ---- */

/* The row of tables[0] or tables[1] named name (exactly, else by a unique prefix, as
 * getopt_long allows); *which tells the table. NULL when none or ambiguous (*ambiguous set). */
static const cli_option *find_long(const cli_option *const tables[2], const char *name, size_t len, int *which,
                                   int *ambiguous)
{
    const cli_option *hit = NULL;
    int hits = 0;
    *ambiguous = 0;
    for (int t = 0; t < 2; t++)
        for (const cli_option *o = tables[t]; o && o->name; o++)
            if (strlen(o->name) == len && !strncmp(o->name, name, len))
                return *which = t, o;
    for (int t = 0; t < 2; t++)
        for (const cli_option *o = tables[t]; o && o->name; o++)
            if (!strncmp(o->name, name, len) && !(o->flags & CLI_HIDDEN))
                hit = o, *which = t, hits++;
    *ambiguous = hits > 1;
    return hits == 1 ? hit : NULL;
}

static const cli_option *find_short(const cli_option *const tables[2], char c, int *which)
{
    for (int t = 0; t < 2; t++)
        for (const cli_option *o = tables[t]; o && o->name; o++)
            if (o->short_name && o->short_name == c)
                return *which = t, o;
    return NULL;
}

/* ---- walking argv ---- */

typedef struct walk {
    const cli_program *p;
    const cli_command *cmd;
    const cli_option *tables[2]; /* the command's rows, the globals */
    void *dest[2];               /* where each table's values go (NULL: keep the token) */
    int help;                    /* -h or --help seen */
    int n_globals;               /* global options taken */
    const char *first_global;    /* the first of them, for messages */
} walk;

/* One option token at argv[*i] (and its value). *keep is set when the token is not for this
 * walk (dest NULL) and stays in argv. */
static int take_option(walk *w, int argc, char **argv, int *i, int *keep)
{
    const char *a = argv[*i], *value = NULL;
    const cli_option *o;
    int which = 0, ambiguous = 0, is_long = a[1] == '-';
    *keep = 0;
    if (!strcmp(a, "--help") || !strcmp(a, "-h"))
        return w->help = 1, EX_OK;
    if (is_long) {
        const char *eq = strchr(a + 2, '=');
        size_t len = eq ? (size_t)(eq - a - 2) : strlen(a + 2);
        o = find_long(w->tables, a + 2, len, &which, &ambiguous);
        value = eq ? eq + 1 : NULL;
    } else {
        o = find_short(w->tables, a[1], &which);
        value = a[2] ? a + 2 : NULL;
    }
    if (!o)
        return usage_error(w->p, w->cmd, "%s option '%s'", ambiguous ? "ambiguous" : "unknown", a);
    if (!cli_takes_value(o) && value)
        return usage_error(w->p, w->cmd, "option --%s takes no value, got '%s'", o->name, a);
    if (cli_takes_value(o) && !value) {
        if (*i + 1 >= argc)
            return usage_error(w->p, w->cmd, "option --%s needs a value (%s)", o->name, o->metavar ? o->metavar : "");
        value = argv[++*i];
    }
    if (!w->dest[which])
        return *keep = 1, EX_OK;
    if (which == 1 && !w->n_globals++)
        w->first_global = o->name;
    return set_value(w->p, w->cmd, o, value, w->dest[which]);
}

/* "-1", "-2.5", "-.5": a number, not an option, unless a table has that short option; it stays a
 * positional argument, so that its range check names it ("sim illuminant -1" said "unknown option"). */
static int looks_negative(const walk *w, const char *a)
{
    int which;
    int digit = (a[1] >= '0' && a[1] <= '9') || (a[1] == '.' && a[2] >= '0' && a[2] <= '9');
    return digit && !find_short(w->tables, a[1], &which);
}

/* Walk argv[1..]: options for a dest table are taken out, the rest (positional arguments and,
 * with dest[t] NULL, table t's options with their values) stay in order. @return EX_OK or
 * EX_USAGE; *argc becomes the count left. */
static int walk_args(walk *w, int *argc, char **argv)
{
    int out = 1, rc = EX_OK, options_done = 0;
    for (int i = 1; rc == EX_OK && i < *argc; i++) {
        const char *a = argv[i];
        int keep = 1, start = i;
        if (!options_done && !strcmp(a, "--")) {
            options_done = 1;
            if (w->dest[0]) /* the command's own walk: "--" is spent */
                continue;
        } else if (!options_done && a[0] == '-' && a[1] && !looks_negative(w, a)) {
            rc = take_option(w, *argc, argv, &i, &keep);
        }
        for (int k = start; keep && k <= i; k++)
            argv[out++] = argv[k];
    }
    *argc = out;
    argv[out] = NULL;
    return rc;
}

static int check_required(const cli_program *p, const cli_command *cmd, const void *opts)
{
    for (const cli_option *o = cmd->options; o && o->name; o++) {
        if (!(o->flags & CLI_REQUIRED))
            continue;
        const void *f = (const char *)opts + o->offset;
        int given = o->kind == CLI_STRING ? *(const char *const *)f != NULL
                    : o->given            ? *(const int *)((const char *)opts + o->given - 1)
                                          : 1;
        if (!given && o->short_name)
            return usage_error(p, cmd, "option -%c %s is required", o->short_name, o->metavar ? o->metavar : "");
        if (!given)
            return usage_error(p, cmd, "option --%s %s is required", o->name, o->metavar ? o->metavar : "");
    }
    return EX_OK;
}

/* After the walk: the count of positional arguments, then the required options. */
static int finish_parse(const cli_program *p, const cli_command *cmd, int argc, char **argv, const void *opts,
                        int *n_args)
{
    *n_args = argc - 1;
    if (*n_args < cmd->min_args || *n_args > cmd->max_args) {
        if (cmd->max_args == 0)
            return usage_error(p, cmd, "unexpected argument '%s'", argv[1]);
        return usage_error(p, cmd, "expected %d..%d arguments (%s), got %d", cmd->min_args, cmd->max_args,
                           cmd->args ? cmd->args : "", *n_args);
    }
    return check_required(p, cmd, opts);
}

int cli_parse(const cli_program *p, const cli_command *cmd, int argc, char **argv, void *opts, int *n_args)
{
    walk w = {.p = p, .cmd = cmd, .tables = {cmd->options, NULL}, .dest = {opts, NULL}};
    int rc = walk_args(&w, &argc, argv);
    if (rc == EX_OK && w.help) /* cli_main answers --help before a command runs */
        rc = usage_error(p, cmd, "--help cannot be combined here");
    return rc == EX_OK ? finish_parse(p, cmd, argc, argv, opts, n_args) : rc;
}

/* ---- programs ---- */

const cli_command *cli_find_command(const cli_program *p, int argc, char **argv, int *words)
{
    for (const cli_command *const *c = p->commands; c && *c; c++) {
        const char *name = (*c)->name, *space = strchr(name, ' ');
        if (!space && argc >= 1 && !strcmp(argv[0], name))
            return *words = 1, *c;
        if (space && argc >= 2 && strlen(argv[0]) == (size_t)(space - name) &&
            !strncmp(argv[0], name, (size_t)(space - name)) && !strcmp(argv[1], space + 1))
            return *words = 2, *c;
    }
    return NULL;
}

/* --version, --man, --bash-completion, --values KIND (for the completion): answered before
 * anything else. */
static int program_request(const cli_program *p, int argc, char **argv, int *done)
{
    const char *a = argv[1];
    *done = 1;
    if (!strcmp(a, "--version"))
        cli_print_version(stdout, p->name);
    else if (!strcmp(a, "--man"))
        cli_print_man(stdout, p);
    else if (!strcmp(a, "--bash-completion"))
        cli_print_bash_completion(stdout, p);
    else if (!strcmp(a, "--values") && argc >= 3 && p->print_values)
        p->print_values(stdout, argv[2]);
    else
        *done = 0;
    return EX_OK;
}

static int help_command(const cli_program *p, int argc, char **argv)
{
    int words = 0;
    if (argc == 0)
        return cli_print_program_help(stdout, p), EX_OK;
    const cli_command *cmd = cli_find_command(p, argc, argv, &words);
    if (!cmd || words != argc)
        return usage_error(p, NULL, "help: unknown command '%s%s%s'", argv[0], argc > 1 ? " " : "",
                           argc > 1 ? argv[1] : "");
    cli_print_command_help(stdout, p, cmd);
    return EX_OK;
}

static int run_command(const cli_program *p, const cli_command *cmd, int argc, char **argv, void *globals,
                       const char *leading)
{
    walk w = {.p = p, .cmd = cmd, .tables = {cmd->options, p->globals}, .dest = {NULL, globals}};
    int rc = walk_args(&w, &argc, argv);
    if (rc != EX_OK)
        return rc;
    if (w.help)
        return cli_print_command_help(stdout, p, cmd), EX_OK;
    if ((w.n_globals || leading) && !(cmd->flags & CLI_CMD_BOARD))
        return usage_error(p, cmd, "option --%s: this command does not talk to a board",
                           leading ? leading : w.first_global);
    return cmd->run(argc, argv);
}

int cli_main(const cli_program *p, int argc, char **argv, void *globals)
{
    int done = 0, i = 1, words = 0;
    if (argc >= 2 && program_request(p, argc, argv, &done) == EX_OK && done)
        return EX_OK;
    /* Global options before the command (they may also follow it). */
    walk w = {.p = p, .tables = {NULL, p->globals}, .dest = {NULL, globals}};
    int keep, rc = EX_OK;
    for (; rc == EX_OK && i < argc && argv[i][0] == '-' && argv[i][1] && strcmp(argv[i], "--"); i++)
        rc = take_option(&w, argc, argv, &i, &keep);
    if (rc != EX_OK)
        return rc;
    if (i >= argc) {
        cli_print_program_help(w.help ? stdout : stderr, p);
        return w.help ? EX_OK : EX_USAGE;
    }
    if (!strcmp(argv[i], "help"))
        return help_command(p, argc - i - 1, argv + i + 1);
    const cli_command *cmd = cli_find_command(p, argc - i, argv + i, &words);
    if (!cmd) {
        fprintf(stderr, "%s: unknown command '%s%s%s'\n", p->name, argv[i], i + 1 < argc ? " " : "",
                i + 1 < argc ? argv[i + 1] : "");
        cli_print_program_help(stderr, p);
        return EX_USAGE;
    }
    if (w.help)
        return cli_print_command_help(stdout, p, cmd), EX_OK;
    /* argv[0] of the command is its last word. */
    int first = i + words - 1;
    return run_command(p, cmd, argc - first, argv + first, globals, w.first_global);
}

int cli_main_single(const cli_program *p, int argc, char **argv, void *opts, int *n_args, int *done)
{
    *done = 0;
    if (argc >= 2 && program_request(p, argc, argv, done) == EX_OK && *done)
        return EX_OK;
    walk w = {.p = p, .cmd = p->single, .tables = {p->single->options, NULL}, .dest = {opts, NULL}};
    int rc = walk_args(&w, &argc, argv);
    if (rc == EX_OK && w.help) {
        *done = 1;
        cli_print_command_help(stdout, p, p->single);
        return EX_OK;
    }
    return rc == EX_OK ? finish_parse(p, p->single, argc, argv, opts, n_args) : rc;
}
