/* The values shell completion offers for --board, --scene, --operator and --device: PROG --values KIND
 * (cli_program.print_values) of wdrctl and wdrsim. */
#ifndef WDR_VALUE_LISTS_H
#define WDR_VALUE_LISTS_H
#include <stdio.h>

/* boards, scenes (sim/data_path.h), operators or devices (every transport's prefix and the
 * serial ports present), one per line; another kind prints nothing. */
void wdr_print_values(FILE *f, const char *kind);

#endif
