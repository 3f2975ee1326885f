/* Plots through gnuplot (a Debian package), fed a script on its standard input. */
#ifndef WDR_PLOT_H
#define WDR_PLOT_H

/* Run gnuplot on script. @retval WDR_OK, WDR_E_UNSUPPORTED (no gnuplot), WDR_E_IO (it failed) */
int wdr_gnuplot_run(const char *script, char *err, int errlen);

/* A fresh private directory for plot data; out gets its path. @retval WDR_OK, WDR_E_IO */
int wdr_plot_tmpdir(char *out, int outlen);

/* Remove the data files and the directory made by wdr_plot_tmpdir. */
void wdr_plot_tmpdir_remove(const char *dir);

#endif
