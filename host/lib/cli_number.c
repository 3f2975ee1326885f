/* The one strict number parser (see cli_number.h). */
#include "cli_number.h"
#include <ctype.h>
#include <errno.h>
#include <limits.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

/* strto* skip leading blanks and read "0x"; we want the whole text and nothing but a number. */
static int starts_clean(const char *text) { return text && *text && !isspace((unsigned char)*text); }

/* Digits only (after an optional sign): "1e3", "0.5", "010x" are not integers. */
static int integer_syntax(const char *p)
{
    if (*p == '+' || *p == '-')
        p++;
    int hex = p[0] == '0' && (p[1] == 'x' || p[1] == 'X');
    p += hex ? 2 : 0;
    if (!*p)
        return 0;
    for (; *p; p++)
        if (!(hex ? isxdigit((unsigned char)*p) : isdigit((unsigned char)*p)))
            return 0;
    return 1;
}

static int base_of(const char *text)
{
    const char *p = text + (*text == '+' || *text == '-');
    return p[0] == '0' && (p[1] == 'x' || p[1] == 'X') ? 16 : 10;
}

int cli_number_long(const char *text, long long lo, long long hi, long long *out)
{
    if (!starts_clean(text) || !integer_syntax(text))
        return CLI_NUM_NOT_INTEGER;
    const char *digits = text + (*text == '+' || *text == '-');
    errno = 0;
    unsigned long long mag = strtoull(digits, NULL, base_of(text));
    int neg = *text == '-';
    if (errno == ERANGE || mag > (unsigned long long)LLONG_MAX + (unsigned long long)neg)
        return CLI_NUM_RANGE;
    long long v = neg ? (mag == (unsigned long long)LLONG_MAX + 1ull ? LLONG_MIN : -(long long)mag) : (long long)mag;
    if (v < lo || v > hi)
        return CLI_NUM_RANGE;
    *out = v;
    return CLI_NUM_OK;
}

int cli_number_u64(const char *text, uint64_t lo, uint64_t hi, uint64_t *out)
{
    if (!starts_clean(text) || !integer_syntax(text))
        return CLI_NUM_NOT_INTEGER;
    if (*text == '-')
        return CLI_NUM_NEGATIVE;
    errno = 0;
    unsigned long long v = strtoull(text + (*text == '+'), NULL, base_of(text));
    if (errno == ERANGE || v < lo || v > hi)
        return CLI_NUM_RANGE;
    *out = v;
    return CLI_NUM_OK;
}

int cli_number_double(const char *text, double lo, double hi, double *out)
{
    char *end;
    if (!starts_clean(text))
        return CLI_NUM_NOT_NUMBER;
    errno = 0;
    double v = strtod(text, &end);
    if (end == text || *end || !isfinite(v))
        return CLI_NUM_NOT_NUMBER;
    if (!(v >= lo && v <= hi))
        return CLI_NUM_RANGE;
    *out = v;
    return CLI_NUM_OK;
}

void cli_number_message(int error, const char *what, const char *text, double lo, double hi, int integer, char *msg,
                        size_t cap)
{
    if (error == CLI_NUM_NOT_INTEGER)
        snprintf(msg, cap, "%s: '%s' is not an integer", what, text);
    else if (error == CLI_NUM_NEGATIVE)
        snprintf(msg, cap, "%s: '%s' is negative, a non-negative integer is needed", what, text);
    else if (error == CLI_NUM_NOT_NUMBER)
        snprintf(msg, cap, "%s: '%s' is not a finite number", what, text);
    else if (integer && hi >= 18446744073709551615.0)
        snprintf(msg, cap, "%s: '%s' is too large", what, text);
    else if (integer)
        snprintf(msg, cap, "%s: '%s' is out of range %.0f..%.0f", what, text, lo, hi);
    else
        snprintf(msg, cap, "%s: '%s' is out of range %g..%g", what, text, lo, hi);
}
