/* wdr-simboard's own command line: bad arguments and bad files give a sysexits code, and a
 * message naming what is wrong, before anything listens. */
#include "e2e_board.h"
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <cmocka.h>
#include <stdio.h>
#include <stdlib.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <sysexits.h>
#include <unistd.h>

extern char **environ;

#define BOARD WDR_SOURCE_DIR "/boards/sim-qvga/board.json"
#define SCENE WDR_SOURCE_DIR "/sim/scenes/window.json"

static void bad_command_lines(void **state)
{
    (void)state;
    char *none[] = {WDR_SIMBOARD_PATH, NULL};
    char *no_scene[] = {WDR_SIMBOARD_PATH, "--board", BOARD, NULL};
    char *bad_seed[] = {WDR_SIMBOARD_PATH, "--board", BOARD, "--scene", SCENE, "--seed", "-3", NULL};
    char *extra[] = {WDR_SIMBOARD_PATH, "--board", BOARD, "--scene", SCENE, "stray", NULL};
    assert_int_equal(e2e_run(none, 20), EX_USAGE);
    assert_int_equal(e2e_run(no_scene, 20), EX_USAGE);
    assert_int_equal(e2e_run(bad_seed, 20), EX_USAGE);
    assert_int_equal(e2e_run(extra, 20), EX_USAGE);
}

static void bad_files(void **state)
{
    (void)state;
    char *no_board[] = {WDR_SIMBOARD_PATH, "--board", "/nonexistent/board.json", "--scene", SCENE, NULL};
    char *no_scene[] = {WDR_SIMBOARD_PATH, "--board", BOARD, "--scene", "/nonexistent/scene.json", NULL};
    char *not_a_scene[] = {WDR_SIMBOARD_PATH, "--board", BOARD, "--scene", BOARD, NULL};
    char *bad_socket[] = {WDR_SIMBOARD_PATH, "--board", BOARD, "--scene", SCENE, "--socket",
                          "/nonexistent/dir/board.sock", NULL};
    assert_int_equal(e2e_run(no_board, 20), EX_NOINPUT);
    assert_int_equal(e2e_run(no_scene, 20), EX_NOINPUT);
    assert_int_equal(e2e_run(not_a_scene, 20), EX_DATAERR);
    assert_int_equal(e2e_run(bad_socket, 20), EX_CANTCREAT);
}

/* --firmware: a missing image file, and one larger than slot A (2 MiB image flash). */
static void bad_firmware_files(void **state)
{
    (void)state;
    char dir[] = "/tmp/wdr-fwcli-XXXXXX", sock[128], big[128];
    assert_non_null(mkdtemp(dir));
    snprintf(sock, sizeof sock, "%s/b.sock", dir);
    snprintf(big, sizeof big, "%s/big.img", dir);
    FILE *f = fopen(big, "wb");
    assert_non_null(f);
    assert_int_equal(fseek(f, 1536L * 1024L, SEEK_SET), 0);
    assert_int_equal(fputc(0, f), 0);
    assert_int_equal(fclose(f), 0);
    char *missing[] = {WDR_SIMBOARD_PATH, "--board", BOARD, "--scene", SCENE, "--socket", sock,
                       "--firmware", "/nonexistent/app.img", NULL};
    char *too_big[] = {WDR_SIMBOARD_PATH, "--board", BOARD, "--scene", SCENE, "--socket", sock, "--firmware", big, NULL};
    assert_int_equal(e2e_run(missing, 20), EX_NOINPUT);
    assert_int_equal(e2e_run(too_big, 20), EX_DATAERR);
    unlink(big);
    rmdir(dir);
}

/* wdrctl --wait finds a board that is still starting; wdr-simboard --once ends, cleanly, when
 * that host leaves. */
static void wait_and_once(void **state)
{
    (void)state;
    char dir[] = "/tmp/wdr-once-XXXXXX", sock[128], addr[160];
    assert_non_null(mkdtemp(dir));
    snprintf(sock, sizeof sock, "%s/b.sock", dir);
    snprintf(addr, sizeof addr, "sim:%s", sock);
    char *board[] = {WDR_SIMBOARD_PATH, "--board", BOARD, "--scene", SCENE, "--socket", sock, "--once", NULL};
    char *info[] = {WDRCTL_PATH, "info", "--wait", "15000", "--device", addr, NULL};
    pid_t pid;
    assert_int_equal(posix_spawn(&pid, WDR_SIMBOARD_PATH, NULL, NULL, board, environ), 0);
    assert_int_equal(e2e_run(info, 30), EX_OK);
    int status = -1;
    for (int ms = 0; ms < 10000 && waitpid(pid, &status, WNOHANG) == 0; ms += 10)
        usleep(10000);
    if (!WIFEXITED(status)) {
        kill(pid, SIGKILL);
        waitpid(pid, &status, 0);
    }
    assert_true(WIFEXITED(status) && WEXITSTATUS(status) == 0);
    rmdir(dir);
}

int main(void)
{
    const struct CMUnitTest tests[] = {cmocka_unit_test(bad_command_lines), cmocka_unit_test(bad_files),
                                       cmocka_unit_test(bad_firmware_files),
                                       cmocka_unit_test(wait_and_once)};
    return cmocka_run_group_tests(tests, NULL, NULL);
}
