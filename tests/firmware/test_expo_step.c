/* Auto exposure's step rule (wdr_fw_expo_step, fw_expo.c), by the cases that set it: half of a
 * small gap, truncated; a gap past 0.5 ln closed to 0.25 ln at once; a last 1/256 taken only when
 * two frames in a row ask for it alike, so that an estimate flipping by 1/256 does not drive a
 * limit cycle. Each rule was measured on e2e_auto_exposure_scenes (the figures are in fw_expo.c). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <cmocka.h>
#include "wdr_fw.h"

static void small_gaps_move_half_way(void **state)
{
    (void)state;
    int8_t nudge = 0;
    assert_int_equal(wdr_fw_expo_step(100, &nudge), 50);
    assert_int_equal(wdr_fw_expo_step(-101, &nudge), -50); /* truncated toward the gain in force */
    assert_int_equal(wdr_fw_expo_step(3, &nudge), 1);
    assert_int_equal(wdr_fw_expo_step(128, &nudge), 64);
    assert_int_equal(nudge, 0);
}

static void large_gaps_close_to_a_quarter_ln(void **state)
{
    (void)state;
    int8_t nudge = 0;
    assert_int_equal(wdr_fw_expo_step(129, &nudge), 65); /* continuous at the edge */
    assert_int_equal(wdr_fw_expo_step(400, &nudge), 336);
    assert_int_equal(wdr_fw_expo_step(-4000, &nudge), -3936);
}

static void a_last_step_of_one_after_two_frames_alike(void **state)
{
    (void)state;
    int8_t nudge = 0;
    assert_int_equal(wdr_fw_expo_step(1, &nudge), 0);
    assert_int_equal(wdr_fw_expo_step(1, &nudge), 1); /* the stall the halving left is taken */
    assert_int_equal(wdr_fw_expo_step(1, &nudge), 0); /* and the count starts again */
    assert_int_equal(wdr_fw_expo_step(-1, &nudge), 0);
    assert_int_equal(wdr_fw_expo_step(-1, &nudge), -1);
}

static void a_flipping_estimate_never_moves_the_gain(void **state)
{
    (void)state;
    int8_t nudge = 0;
    for (int f = 0; f < 8; f++)
        assert_int_equal(wdr_fw_expo_step(f % 2 ? -1 : 1, &nudge), 0);
    assert_int_equal(wdr_fw_expo_step(1, &nudge), 0);
    assert_int_equal(wdr_fw_expo_step(0, &nudge), 0); /* a frame on target forgets the one before */
    assert_int_equal(wdr_fw_expo_step(1, &nudge), 0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(small_gaps_move_half_way),
        cmocka_unit_test(large_gaps_close_to_a_quarter_ln),
        cmocka_unit_test(a_last_step_of_one_after_two_frames_alike),
        cmocka_unit_test(a_flipping_estimate_never_moves_the_gain),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
