/* wdr-simboard's own command line: bad arguments and bad files give a sysexits code, and a
 * message naming what is wrong, before anything listens. */
#include "e2e_board.h"
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <cmocka.h>
#include <stdio.h>
#include <stdlib.h>
#include <sysexits.h>

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

int main(void)
{
    const struct CMUnitTest tests[] = {cmocka_unit_test(bad_command_lines), cmocka_unit_test(bad_files)};
    return cmocka_run_group_tests(tests, NULL, NULL);
}
