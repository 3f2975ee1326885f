/* Plots through gnuplot (a Debian package), fed a script on its standard input. */
#ifndef WDR_PLOT_H
#define WDR_PLOT_H

#include <stddef.h>

/* Run gnuplot on script. Its messages (warnings included) are captured: dropped when it
 * succeeds, the first lines in err when it fails. Nothing reaches the terminal.
 * @retval WDR_OK, WDR_E_UNSUPPORTED (no gnuplot), WDR_E_IO (it failed) */
int wdr_gnuplot_run(const char *script, char *err, int errlen);

/* The one look of series k (an operator's or a calibration model's id): colour, dash and point
 * type, distinct for every k below 12, the same in every panel of every plot. Dashes differ
 * too, so curves that coincide still show each colour. */
const char *wdr_plot_style(int k);

/* Append to script (at most cap bytes) the clauses of one series, column col of data, in the
 * style of series k, on a log y axis whose floor is floor: values at or above the floor as a
 * line with points, values below it (zero included) at the floor with a down-triangle in the
 * same colour, the line joining them all. Each clause starts with ", ". @return the characters
 * written */
int wdr_plot_floored_series(char *script, size_t cap, const char *data, int col, int k, const char *title,
                            double floor);

/* The key entry that says what the down-triangle means ("below 0.01 %: drawn at the floor");
 * unit follows the value ("" for none). @return the characters written */
int wdr_plot_floor_key(char *script, size_t cap, double floor, const char *unit);

/* A fresh private directory for plot data; out gets its path. @retval WDR_OK, WDR_E_IO */
int wdr_plot_tmpdir(char *out, int outlen);

/* Remove the data files and the directory made by wdr_plot_tmpdir. */
void wdr_plot_tmpdir_remove(const char *dir);

#endif
