/* Declarative command lines: --help, `help CMD`, the man page and the bash completion, all
 * from the option tables (see cli_options.h). */
#include "cli_options.h"
#include <string.h>

/* ---- pieces of text ---- */

/* "uniform|stamped" for a choice without a metavar. */
static const char *metavar(const cli_option *o, char *buf, size_t cap)
{
    if (o->metavar || o->kind != CLI_CHOICE)
        return o->metavar ? o->metavar : "";
    buf[0] = 0;
    for (const cli_choice *c = o->choices; c->name; c++)
        snprintf(buf + strlen(buf), cap - strlen(buf), "%s%s", c == o->choices ? "" : "|", c->name);
    return buf;
}

/* "-o, --output FILE" */
static void option_label(const cli_option *o, char *out, size_t cap)
{
    char mv[128];
    const char *m = metavar(o, mv, sizeof mv);
    if (o->short_name)
        snprintf(out, cap, "-%c, --%s%s%s", o->short_name, o->name, *m ? " " : "", m);
    else
        snprintf(out, cap, "--%s%s%s", o->name, *m ? " " : "", m);
}

/* Add "what" to a help line: inside its closing parenthesis if it ends with one. */
static size_t add_note(char *out, size_t n, size_t cap, const char *what)
{
    if (n >= cap)
        return n;
    if (n > 0 && out[n - 1] == ')')
        return n - 1 + (size_t)snprintf(out + n - 1, cap - n + 1, "; %s)", what);
    return n + (size_t)snprintf(out + n, cap - n, " (%s)", what);
}

/* The help line and what the table knows besides: range, repeatable, required. */
static void option_help(const cli_option *o, char *out, size_t cap)
{
    char note[96] = "";
    size_t n = (size_t)snprintf(out, cap, "%s", o->help ? o->help : "");
    if (o->kind == CLI_INT)
        snprintf(note, sizeof note, "%.0f..%.0f", o->min, o->max);
    else if (o->kind == CLI_DOUBLE && (o->min != 0 || o->max != 0))
        snprintf(note, sizeof note, "%g..%g", o->min, o->max);
    else if (o->kind == CLI_LIST)
        snprintf(note, sizeof note, "repeatable, up to %d", (int)o->max);
    if (note[0])
        n = add_note(out, n, cap, note);
    if (o->flags & CLI_REQUIRED)
        add_note(out, n, cap, "required");
}

/* A paragraph folded at 96 columns after indent spaces. */
static void print_wrapped(FILE *f, const char *text, int indent)
{
    const char *p = text;
    while (*p) {
        size_t len = strlen(p), take = len;
        if (len > (size_t)(96 - indent)) {
            take = (size_t)(96 - indent);
            while (take > 0 && p[take] != ' ')
                take--;
            take = take ? take : (size_t)(96 - indent);
        }
        fprintf(f, "%*s%.*s\n", indent, "", (int)take, p);
        p += take;
        while (*p == ' ')
            p++;
    }
}

static int has_optional(const cli_command *cmd)
{
    for (const cli_option *o = cmd->options; o && o->name; o++)
        if (!(o->flags & (CLI_REQUIRED | CLI_HIDDEN)))
            return 1;
    return 0;
}

/* "wdrctl lut build --operator NAME -o LUT.bin [options]" */
static void synopsis(const cli_program *p, const cli_command *cmd, char *out, size_t cap)
{
    size_t n = (size_t)snprintf(out, cap, "%s%s%s", p->name, cmd->name ? " " : "", cmd->name ? cmd->name : "");
    for (const cli_option *o = cmd->options; n < cap && o && o->name; o++)
        if (o->flags & CLI_REQUIRED) {
            char mv[128];
            const char *m = metavar(o, mv, sizeof mv);
            if (o->short_name)
                n += (size_t)snprintf(out + n, cap - n, " -%c %s", o->short_name, m);
            else
                n += (size_t)snprintf(out + n, cap - n, " --%s%s%s", o->name, *m ? " " : "", m);
        }
    if (n < cap && has_optional(cmd))
        n += (size_t)snprintf(out + n, cap - n, " [options]");
    if (n < cap && cmd->args)
        snprintf(out + n, cap - n, " %s", cmd->args);
}

/* ---- --help ---- */

static void print_rows(FILE *f, const cli_option *rows)
{
    char label[192], help[512];
    for (const cli_option *o = rows; o && o->name; o++) {
        if (o->flags & CLI_HIDDEN)
            continue;
        option_label(o, label, sizeof label);
        option_help(o, help, sizeof help);
        if (strlen(label) <= 26)
            fprintf(f, "  %-26s %s\n", label, help);
        else
            fprintf(f, "  %s\n  %-26s %s\n", label, "", help);
    }
}

void cli_print_command_help(FILE *f, const cli_program *p, const cli_command *cmd)
{
    char syn[1024];
    synopsis(p, cmd, syn, sizeof syn);
    fprintf(f, "usage: %s\n\n", syn);
    print_wrapped(f, cmd->summary ? cmd->summary : p->summary, 0);
    if (cmd->details) {
        fputc('\n', f);
        print_wrapped(f, cmd->details, 0);
    }
    fprintf(f, "\noptions:\n");
    print_rows(f, cmd->options);
    fprintf(f, "  %-26s %s\n", "-h, --help", "show this help");
    if (cmd->flags & CLI_CMD_BOARD) {
        fprintf(f, "\nglobal options (before or after the command):\n");
        print_rows(f, p->globals);
    }
}

void cli_print_program_help(FILE *f, const cli_program *p)
{
    if (!p->commands) {
        cli_print_command_help(f, p, p->single);
        return;
    }
    fprintf(f, "usage: %s [global options] COMMAND [options] [ARGS]\n", p->name);
    fprintf(f, "       %s help COMMAND   (or %s COMMAND --help): the options of one command\n", p->name, p->name);
    fprintf(f, "       %s --version\n\n%s\n\ncommands:\n", p->name, p->summary);
    for (const cli_command *const *c = p->commands; *c; c++)
        fprintf(f, "  %-18s %s\n", (*c)->name, (*c)->summary);
    fprintf(f, "\nglobal options (before or after a command that talks to a board):\n");
    print_rows(f, p->globals);
}

/* ---- the man page ---- */

/* troff text: '-' and '\' escaped, no line starting with '.' or '\''. */
static void roff(FILE *f, const char *s)
{
    int bol = 1;
    for (; *s; s++) {
        if (bol && (*s == '.' || *s == '\''))
            fputs("\\&", f);
        if (*s == '-' || *s == '\\')
            fputc('\\', f);
        fputc(*s, f);
        bol = *s == '\n';
    }
}

static void man_rows(FILE *f, const cli_option *rows)
{
    char label[192], help[512];
    for (const cli_option *o = rows; o && o->name; o++) {
        if (o->flags & CLI_HIDDEN)
            continue;
        option_label(o, label, sizeof label);
        option_help(o, help, sizeof help);
        fputs(".TP\n.B ", f);
        roff(f, label);
        fputc('\n', f);
        roff(f, help);
        fputc('\n', f);
    }
}

static void man_command(FILE *f, const cli_program *p, const cli_command *cmd)
{
    char syn[1024];
    synopsis(p, cmd, syn, sizeof syn);
    fputs(".SS \"", f);
    roff(f, cmd->name);
    fputs("\"\n", f);
    fputs(".B ", f);
    roff(f, syn);
    fputs("\n.PP\n", f);
    roff(f, cmd->summary ? cmd->summary : "");
    fputc('\n', f);
    if (cmd->details) {
        fputs(".PP\n", f);
        roff(f, cmd->details);
        fputc('\n', f);
    }
    man_rows(f, cmd->options);
}

static void man_header(FILE *f, const cli_program *p)
{
    char upper[64];
    size_t k = 0;
    for (; p->name[k] && k + 1 < sizeof upper; k++)
        upper[k] = (char)(p->name[k] >= 'a' && p->name[k] <= 'z' ? p->name[k] - 32 : p->name[k]);
    upper[k] = 0;
    fprintf(f, ".\\\" Generated by '%s --man' from its option tables; do not edit.\n", p->name);
    fprintf(f, ".TH %s 1 \"\" \"wdrcam\" \"wdrcam manual\"\n.SH NAME\n", upper);
    roff(f, p->name);
    fputs(" \\- ", f);
    roff(f, p->summary);
    fputc('\n', f);
}

static void man_description(FILE *f, const cli_program *p)
{
    fputs(".SH DESCRIPTION\n", f);
    roff(f, p->description ? p->description : p->summary);
    fputc('\n', f);
}

void cli_print_man(FILE *f, const cli_program *p)
{
    man_header(f, p);
    if (!p->commands) {
        char syn[1024];
        synopsis(p, p->single, syn, sizeof syn);
        fputs(".SH SYNOPSIS\n.B ", f);
        roff(f, syn);
        fputc('\n', f);
        man_description(f, p);
        fputs(".SH OPTIONS\n", f);
        man_rows(f, p->single->options);
    } else {
        fprintf(f, ".SH SYNOPSIS\n.B %s\n[\\fIglobal options\\fR] \\fICOMMAND\\fR [\\fIoptions\\fR] [\\fIARGS\\fR]\n",
                p->name);
        man_description(f, p);
        fputs(".SH GLOBAL OPTIONS\nAccepted before or after any command that talks to a board.\n", f);
        man_rows(f, p->globals);
        fputs(".SH COMMANDS\n", f);
        for (const cli_command *const *c = p->commands; *c; c++)
            man_command(f, p, *c);
    }
    fputs(".SH \"COMMON OPTIONS\"\n.TP\n.B \\-h, \\-\\-help\nthe options of the program or command\n"
          ".TP\n.B \\-\\-version\nthe version, with the wire protocol and table format versions it speaks\n", f);
    for (const cli_section *s = p->sections; s && s->title; s++) {
        int lines = !strcmp(s->title, "EXAMPLES") || !strcmp(s->title, "ENVIRONMENT"); /* one per line, as typed */
        fprintf(f, ".SH \"%s\"\n%s", s->title, lines ? ".nf\n" : "");
        roff(f, s->text);
        fputs(lines ? "\n.fi\n" : "\n", f);
    }
}

/* ---- bash completion ---- */

static void words_of(FILE *f, const cli_option *rows)
{
    for (const cli_option *o = rows; o && o->name; o++)
        if (!(o->flags & CLI_HIDDEN))
            fprintf(f, o->short_name ? " -%2$c --%1$s" : " --%1$s", o->name, o->short_name);
}

/* Every option that takes a value, so that its value is not taken for a command word. */
static void value_options(FILE *f, const cli_program *p)
{
    for (const cli_option *o = p->globals; o && o->name; o++)
        if (cli_takes_value(o))
            fprintf(f, " --%s", o->name);
    for (const cli_command *const *c = p->commands; c && *c; c++)
        for (const cli_option *o = (*c)->options; o && o->name; o++)
            if (cli_takes_value(o))
                fprintf(f, o->short_name ? " --%1$s -%2$c" : " --%1$s", o->name, o->short_name);
    for (const cli_option *o = p->single ? p->single->options : NULL; o && o->name; o++)
        if (cli_takes_value(o))
            fprintf(f, o->short_name ? " --%1$s -%2$c" : " --%1$s", o->name, o->short_name);
}

static int completes_value(const cli_option *o) { return o->kind == CLI_CHOICE || o->values; }

/* The first row of this name with values to complete, to write each option's case once. */
static int first_of_name(const cli_program *p, const cli_option *row)
{
    for (const cli_command *const *c = p->commands; c && *c; c++)
        for (const cli_option *o = (*c)->options; o && o->name; o++)
            if (completes_value(o) && !strcmp(o->name, row->name))
                return o == row;
    return 1;
}

/* A row's values: its choices, its words, or the names the program lists ("@KIND"); a value
 * that may also be a file (boards, scenes) completes file names too. */
static void value_case(FILE *f, const cli_program *p, const cli_option *o)
{
    if (o->kind == CLI_CHOICE) {
        fprintf(f, "    --%s) COMPREPLY=($(compgen -W \"", o->name);
        for (const cli_choice *c = o->choices; c->name; c++)
            fprintf(f, "%s%s", c == o->choices ? "" : " ", c->name);
        fputs("\" -- \"$cur\")); return ;;\n", f);
    } else if (o->values[0] == '@') {
        int files = o->metavar && strstr(o->metavar, "FILE"); /* NAME|FILE */
        fprintf(f, "    --%s) COMPREPLY=($(compgen -W \"$(%s --values %s 2>/dev/null)\" -- \"$cur\")%s); return ;;\n",
                o->name, p->name, o->values + 1, files ? " $(compgen -f -- \"$cur\")" : "");
    } else {
        fprintf(f, "    --%s) COMPREPLY=($(compgen -W \"%s\" -- \"$cur\")); return ;;\n", o->name, o->values);
    }
}

static void choice_cases(FILE *f, const cli_program *p, const cli_option *rows)
{
    for (const cli_option *o = rows; o && o->name; o++)
        if (completes_value(o) && first_of_name(p, o))
            value_case(f, p, o);
}

/* The command (its words) from the words typed so far, or the candidates for the next word. */
static void command_finder(FILE *f, const cli_program *p)
{
    fputs("    case \"${words[0]}\" in\n", f);
    for (const cli_command *const *c = p->commands; *c; c++) {
        const char *space = strchr((*c)->name, ' ');
        if (!space) {
            fprintf(f, "    %s) cmd=%s ;;\n", (*c)->name, (*c)->name);
            continue;
        }
        int group = (int)(space - (*c)->name);
        if (c != p->commands && !strncmp(c[-1]->name, (*c)->name, (size_t)group + 1))
            continue; /* this group's case is written */
        fprintf(f, "    %.*s)\n        if ((${#words[@]} < 2)); then COMPREPLY=($(compgen -W \"", group, (*c)->name);
        for (const cli_command *const *d = c; *d && !strncmp((*d)->name, (*c)->name, (size_t)group + 1); d++)
            fprintf(f, "%s%s", d == c ? "" : " ", (*d)->name + group + 1);
        fprintf(f, "\" -- \"$cur\")); return; fi\n        cmd=\"%.*s ${words[1]}\" ;;\n", group, (*c)->name);
    }
    fputs("    help|'') [[ $cur == -* ]] && COMPREPLY=($(compgen -W \"--help --version", f);
    words_of(f, p->globals);
    fputs("\" -- \"$cur\")) || COMPREPLY=($(compgen -W \"help", f);
    for (const cli_command *const *c = p->commands; *c; c++)
        if (!strchr((*c)->name, ' ') || c == p->commands || strncmp(c[-1]->name, (*c)->name, (size_t)(strchr((*c)->name, ' ') - (*c)->name) + 1))
            fprintf(f, " %.*s", (int)strcspn((*c)->name, " "), (*c)->name);
    fputs("\" -- \"$cur\")); return ;;\n    esac\n", f);
}

static void option_cases(FILE *f, const cli_program *p)
{
    fputs("    case \"$cmd\" in\n", f);
    for (const cli_command *const *c = p->commands; c && *c; c++) {
        fprintf(f, "    \"%s\") opts=\"--help", (*c)->name);
        words_of(f, (*c)->options);
        if ((*c)->flags & CLI_CMD_BOARD)
            words_of(f, p->globals);
        fputs("\" ;;\n", f);
    }
    if (p->single) {
        fputs("    *) opts=\"--help --version", f);
        words_of(f, p->single->options);
        fputs("\" ;;\n", f);
    }
    fputs("    esac\n", f);
}

void cli_print_bash_completion(FILE *f, const cli_program *p)
{
    char fn[64];
    size_t k = 0;
    for (; p->name[k] && k + 1 < sizeof fn; k++)
        fn[k] = p->name[k] == '-' ? '_' : p->name[k];
    fn[k] = 0;
    fprintf(f, "# bash completion for %s, generated by '%s --bash-completion' from its option tables.\n", p->name,
            p->name);
    fprintf(f, "_%s()\n{\n    local cur=${COMP_WORDS[COMP_CWORD]} prev=${COMP_WORDS[COMP_CWORD-1]}\n", fn);
    fputs("    local takes=\"", f);
    value_options(f, p);
    fputs(" \" cmd='' opts='' i w\n    local -a words=()\n", f);
    fputs("    for ((i = 1; i < COMP_CWORD; i++)); do\n        w=${COMP_WORDS[i]}\n"
          "        if [[ $w == -* ]]; then [[ $w != *=* && $takes == *\" $w \"* ]] && ((i++))\n"
          "        else words+=(\"$w\"); fi\n    done\n", f);
    fputs("    case \"$prev\" in\n", f);
    choice_cases(f, p, p->globals);
    for (const cli_command *const *c = p->commands; c && *c; c++)
        choice_cases(f, p, (*c)->options);
    if (p->single)
        choice_cases(f, p, p->single->options);
    fputs("    esac\n    [[ $prev == -* && $takes == *\" $prev \"* ]] && return  # a value: files by default\n", f);
    if (p->commands)
        command_finder(f, p);
    option_cases(f, p);
    fprintf(f, "    [[ $cur == -* ]] && COMPREPLY=($(compgen -W \"$opts\" -- \"$cur\"))\n}\n");
    fprintf(f, "complete -o bashdefault -o default -F _%s %s\n", fn, p->name);
}
