/* The command-line tables (host/lib/cli_options.h) and the one number parser (cli_number.h):
 * what each accepts and refuses, with the exit code and the message naming option and value. */
#include "cli_number.h"
#include "cli_options.h"
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <cmocka.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>
#include <sysexits.h>
#include <unistd.h>

/* ---- the number parser ---- */

static void integers(void **state)
{
    (void)state;
    long long v = 0;
    assert_int_equal(cli_number_long("42", 0, 100, &v), CLI_NUM_OK);
    assert_int_equal(v, 42);
    assert_int_equal(cli_number_long("-7", -10, 10, &v), CLI_NUM_OK);
    assert_int_equal(v, -7);
    assert_int_equal(cli_number_long("0x1F", 0, 100, &v), CLI_NUM_OK);
    assert_int_equal(v, 31);
    assert_int_equal(cli_number_long("010", 0, 100, &v), CLI_NUM_OK); /* decimal, not octal */
    assert_int_equal(v, 10);
    static const char *const junk[] = {"", "abc", "12abc", " 12", "12 ", "1e3", "0.5", "0x", "+", "--1", "1,000"};
    for (size_t k = 0; k < sizeof junk / sizeof junk[0]; k++)
        assert_int_equal(cli_number_long(junk[k], -1000, 1000, &v), CLI_NUM_NOT_INTEGER);
    assert_int_equal(cli_number_long("101", 0, 100, &v), CLI_NUM_RANGE);
    assert_int_equal(cli_number_long("99999999999999999999", 0, 100, &v), CLI_NUM_RANGE);
    assert_int_equal(v, 10); /* a refusal leaves the value alone */
}

static void unsigned_integers(void **state)
{
    (void)state;
    uint64_t v = 0;
    assert_int_equal(cli_number_u64("18446744073709551615", 0, UINT64_MAX, &v), CLI_NUM_OK);
    assert_true(v == UINT64_MAX);
    assert_int_equal(cli_number_u64("18446744073709551616", 0, UINT64_MAX, &v), CLI_NUM_RANGE);
    assert_int_equal(cli_number_u64("-3", 0, UINT64_MAX, &v), CLI_NUM_NEGATIVE); /* strtoull would wrap it */
    assert_int_equal(cli_number_u64("abc", 0, UINT64_MAX, &v), CLI_NUM_NOT_INTEGER);
}

static void floats(void **state)
{
    (void)state;
    double v = 0;
    assert_int_equal(cli_number_double("1e-11", 0, 1, &v), CLI_NUM_OK);
    assert_true(v == 1e-11);
    assert_int_equal(cli_number_double("-0.5", -1, 1, &v), CLI_NUM_OK);
    static const char *const junk[] = {"", "abc", "1.5x", " 1", "nan", "inf", "-inf", "1e999"};
    for (size_t k = 0; k < sizeof junk / sizeof junk[0]; k++)
        assert_int_equal(cli_number_double(junk[k], -1e300, 1e300, &v), CLI_NUM_NOT_NUMBER);
    assert_int_equal(cli_number_double("2", 0, 1, &v), CLI_NUM_RANGE);
}

static void messages(void **state)
{
    (void)state;
    char msg[160];
    cli_number_message(CLI_NUM_NOT_INTEGER, "option --seed", "abc", 0, 0, 1, msg, sizeof msg);
    assert_string_equal(msg, "option --seed: 'abc' is not an integer");
    cli_number_message(CLI_NUM_RANGE, "option --entries", "0", 1, 65536, 1, msg, sizeof msg);
    assert_string_equal(msg, "option --entries: '0' is out of range 1..65536");
}

/* ---- a table ---- */

typedef struct opts {
    const char *name, *list[3];
    int flag, n, n_list, choice, seed_given;
    uint64_t seed;
    double x;
} opts;

#define O(f) offsetof(opts, f)
static const cli_choice colours[] = {{"red", 1}, {"green", 2}, {NULL, 0}};
static const cli_option rows[] = {
    {"name", 'o', CLI_STRING, O(name), "FILE", "a name", .flags = CLI_REQUIRED},
    {"flag", 0, CLI_FLAG, O(flag), NULL, "a flag"},
    {"count", 'n', CLI_INT, O(n), "N", "a count", .min = 1, .max = 10},
    {"seed", 0, CLI_U64, O(seed), "N", "a seed", .given = CLI_GIVEN(opts, seed_given)},
    {"x", 0, CLI_DOUBLE, O(x), "X", "a number", .min = 0, .max = 1},
    {"colour", 0, CLI_CHOICE, O(choice), NULL, "a colour", .choices = colours, .what = "colour"},
    {"item", 0, CLI_LIST, O(list), "V", "an item", .max = 3, .count = O(n_list)},
    {"count-max", 0, CLI_FLAG, O(flag), NULL, "makes --cou ambiguous"},
    {0}};
static const cli_command cmd = {"do it", "ARG", 0, 2, "a test command", NULL, rows, NULL, 0};
static const cli_program prog = {.name = "prog", .summary = "a test program"};

static char err_text[2048];

/* Run cli_parse on the words given (argv[0] first), stderr captured into err_text. */
static int parse(opts *o, int *n_args, char **argv)
{
    int argc = 0;
    while (argv[argc])
        argc++;
    memset(o, 0, sizeof *o);
    fflush(stderr);
    FILE *tmp = tmpfile();
    int saved = dup(2);
    dup2(fileno(tmp), 2);
    int rc = cli_parse(&prog, &cmd, argc, argv, o, n_args);
    fflush(stderr);
    dup2(saved, 2);
    close(saved);
    rewind(tmp);
    size_t n = fread(err_text, 1, sizeof err_text - 1, tmp);
    err_text[n] = 0;
    fclose(tmp);
    return rc;
}

static void table_parses(void **state)
{
    (void)state;
    opts o;
    int n = 0;
    char *argv[] = {"it", "a1", "-o", "out", "--flag", "-n3", "--seed=0x10", "--x", "0.25", "--colour", "green",
                    "--item", "p", "--item", "q", "a2", NULL};
    assert_int_equal(parse(&o, &n, argv), EX_OK);
    assert_string_equal(o.name, "out");
    assert_int_equal(o.flag, 1);
    assert_int_equal(o.n, 3);
    assert_true(o.seed == 16 && o.seed_given);
    assert_true(o.x == 0.25);
    assert_int_equal(o.choice, 2);
    assert_int_equal(o.n_list, 2);
    assert_string_equal(o.list[1], "q");
    assert_int_equal(n, 2); /* positional arguments moved to the front, in order */
    assert_string_equal(argv[1], "a1");
    assert_string_equal(argv[2], "a2");
}

static void table_prefixes_and_dashes(void **state)
{
    (void)state;
    opts o;
    int n = 0;
    char *argv[] = {"it", "--na", "v", "--", "--flag", NULL}; /* a unique prefix, as getopt_long; then args */
    assert_int_equal(parse(&o, &n, argv), EX_OK);
    assert_string_equal(o.name, "v");
    assert_int_equal(o.flag, 0);
    assert_int_equal(n, 1);
    assert_string_equal(argv[1], "--flag");
    char *amb[] = {"it", "-o", "v", "--cou", "2", NULL};
    assert_int_equal(parse(&o, &n, amb), EX_USAGE);
    assert_non_null(strstr(err_text, "ambiguous option '--cou'"));
}

static void table_refuses(void **state)
{
    (void)state;
    opts o;
    int n;
    struct {
        char *argv[12];
        const char *message;
    } cases[] = {
        {{"it", "-o", "v", "--seed", "abc", NULL}, "prog: do it: option --seed: 'abc' is not an integer"},
        {{"it", "-o", "v", "--seed", "-1", NULL}, "option --seed: '-1' is negative"},
        {{"it", "-o", "v", "-n", "11", NULL}, "option --count: '11' is out of range 1..10"},
        {{"it", "-o", "v", "-n", "2.5", NULL}, "option --count: '2.5' is not an integer"},
        {{"it", "-o", "v", "--x", "nan", NULL}, "option --x: 'nan' is not a finite number"},
        {{"it", "-o", "v", "--colour", "blue", NULL}, "option --colour: unknown colour 'blue' (known: red, green)"},
        {{"it", "--item", "1", "--item", "2", "--item", "3", "--item", "4", NULL}, "too many --item options (at most 3)"},
        {{"it", "-o", "v", "--bogus", NULL}, "unknown option '--bogus'"},
        {{"it", "-o", "v", "--flag=1", NULL}, "option --flag takes no value"},
        {{"it", "-o", NULL}, "option --name needs a value (FILE)"},
        {{"it", "a", NULL}, "option -o FILE is required"},
        {{"it", "-o", "v", "a", "b", "c", NULL}, "expected 0..2 arguments (ARG), got 3"},
    };
    for (size_t k = 0; k < sizeof cases / sizeof cases[0]; k++) {
        assert_int_equal(parse(&o, &n, cases[k].argv), EX_USAGE);
        if (!strstr(err_text, cases[k].message))
            fail_msg("case %zu: '%s' lacks '%s'", k, err_text, cases[k].message);
        assert_non_null(strstr(err_text, "(see 'prog do it --help')"));
    }
}

/* The help and the man page list every row that is not hidden, with its range. */
static void help_lists_rows(void **state)
{
    (void)state;
    char text[4096];
    FILE *f = fmemopen(text, sizeof text, "w");
    cli_print_command_help(f, &prog, &cmd);
    fclose(f);
    assert_non_null(strstr(text, "usage: prog do it -o FILE [options] ARG"));
    assert_non_null(strstr(text, "-n, --count N"));
    assert_non_null(strstr(text, "(1..10)"));
    assert_non_null(strstr(text, "--colour red|green"));
    assert_non_null(strstr(text, "(repeatable, up to 3)"));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(integers),      cmocka_unit_test(unsigned_integers),
        cmocka_unit_test(floats),        cmocka_unit_test(messages),
        cmocka_unit_test(table_parses),  cmocka_unit_test(table_prefixes_and_dashes),
        cmocka_unit_test(table_refuses), cmocka_unit_test(help_lists_rows),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
