/* The one strict number parser of every program (wdrctl, wdrsim, wdr-simboard, wdr-board).
 * A number is the whole text: no leading or trailing blanks, no trailing junk. Integers are
 * decimal digits with an optional sign, or 0x and hex digits; floats are what strtod reads,
 * finite. Depends on libc only, so any program may link it. */
#ifndef CLI_NUMBER_H
#define CLI_NUMBER_H
#include <stddef.h>
#include <stdint.h>

/* Why a text was refused (0: it is a number in range). */
enum cli_number_error {
    CLI_NUM_OK = 0,
    CLI_NUM_NOT_INTEGER = -1, /* not digits (or has a fraction, an exponent, junk) */
    CLI_NUM_NOT_NUMBER = -2,  /* not a finite number */
    CLI_NUM_RANGE = -3,       /* a number, outside [lo, hi] */
    CLI_NUM_NEGATIVE = -4,    /* a sign where only non-negative integers go */
};

/* text as a signed integer in [lo, hi]. @retval CLI_NUM_NOT_INTEGER, CLI_NUM_RANGE */
int cli_number_long(const char *text, long long lo, long long hi, long long *out);
/* text as an unsigned integer in [lo, hi]; a leading '-' is refused, never wrapped.
 * @retval CLI_NUM_NOT_INTEGER, CLI_NUM_NEGATIVE, CLI_NUM_RANGE */
int cli_number_u64(const char *text, uint64_t lo, uint64_t hi, uint64_t *out);
/* text as a finite double in [lo, hi]. @retval CLI_NUM_NOT_NUMBER, CLI_NUM_RANGE */
int cli_number_double(const char *text, double lo, double hi, double *out);

/* A message naming what and the text for a refusal ("option --seed: 'abc' is not an integer");
 * lo..hi printed for CLI_NUM_RANGE (integers when integer is set). */
void cli_number_message(int error, const char *what, const char *text, double lo, double hi, int integer, char *msg,
                        size_t cap);

#endif
