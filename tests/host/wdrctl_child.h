/* Running a program (wdrctl) as a child in the host tests: its stdout and stderr into files, a
 * hang guard that kills it, the wall time. Shared by test_wdrctl_exit.c, test_fw_client.c and
 * test_hostile_board.c, which assert on what it returns. */
#ifndef WDR_TEST_WDRCTL_CHILD_H
#define WDR_TEST_WDRCTL_CHILD_H
#include <stddef.h>

#define WDR_CHILD_KILLED (-1)   /* still running after the guard: killed */
#define WDR_CHILD_NO_SPAWN (-2) /* posix_spawn failed */
#define WDR_CHILD_SIGNALLED (-3) /* ended by a signal */

/* Run path with args (NULL-terminated, at most 38) in the environment CI=1, PATH=/usr/bin:/bin;
 * stdout to out_path and stderr to err_path (NULL: /dev/null). *wall_s gets its run time.
 * @return its exit code, or one of WDR_CHILD_* */
int wdr_child_run(const char *path, const char *const *args, const char *out_path, const char *err_path,
                  double guard_s, double *wall_s);

/* A file's text into text[0..cap) (empty when it cannot be read), NUL-terminated. */
void wdr_child_slurp(const char *path, char *text, size_t cap);

#endif
