/* The exposure block's droop array after calibrate's margin (wdr_ramp_lut_refresh_droop): the
 * margin lengthens the integration, so every crossed pixel holds longer, and a tick m times the
 * own adds (m - 1) times that to the droop. The refreshed array must equal one built on the
 * lengthened LUT within 1/256 code (ln_q8 and the dark field untouched), and differ from the copied one where
 * pixels crossed before the old end (at least 3/256 code per unit on sim-qvga's Reinhard ramp,
 * with a 52 mV margin: +46 us on a 1.46 ms integration). */
#include "cal_margin.h"
#include "ramp.h"
#include "wdr_err.h"
#include "wdr_lut.h"
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <cmocka.h>

static wdr_lut_exposure copied, refreshed, rebuilt;

static void block_of(const uint8_t *lut, size_t len, wdr_lut_exposure *ex)
{
    wdr_lut_view v;
    assert_int_equal(wdr_lut_parse(lut, len, &v), WDR_OK);
    size_t end = wdr_lut_size(v.h.entry_count);
    assert_int_equal(wdr_lut_exposure_parse(lut + end, len - end, ex), WDR_OK);
}

static void droop_follows_the_margin(void **state)
{
    (void)state;
    wdr_board b;
    char path[512], err[256];
    wdr_board_path("sim-qvga", path, sizeof path);
    wdr_board_defaults(&b);
    assert_int_equal(wdr_board_load(path, &b, err, sizeof err), WDR_OK);
    uint8_t *lut, *ext;
    size_t len, ext_len;
    double key = 0.18 * b.i_center_a, added, done;
    assert_int_equal(wdr_ramp_board_lut(&b, "reinhard", &lut, &len, NULL, err, sizeof err), WDR_OK);
    assert_int_equal(wdr_ramp_lut_append_exposure(&lut, &len, &b, key), WDR_OK);
    assert_int_equal(wdr_cal_lut_with_margin(lut, len, 0.052, &ext, &ext_len, &added, &done, err, sizeof err), WDR_OK);
    assert_true(added > 0);
    block_of(ext, ext_len, &copied);
    assert_int_equal(wdr_ramp_lut_refresh_droop(ext, ext_len, &b), WDR_OK);
    block_of(ext, ext_len, &refreshed);
    wdr_lut_view v;
    assert_int_equal(wdr_lut_parse(ext, ext_len, &v), WDR_OK);
    assert_int_equal(wdr_ramp_lut_exposure_table(&b, &v, key, &rebuilt), WDR_OK);
    assert_int_equal(refreshed.flags, WDR_LUT_EXPO_DROOP | WDR_LUT_EXPO_DARK);
    assert_int_equal(refreshed.dark_ln_q8, copied.dark_ln_q8);
    assert_memory_equal(refreshed.ln_q8, copied.ln_q8, sizeof copied.ln_q8[0] * copied.bins);
    int grew = 0, worst = 0;
    for (uint32_t k = 0; k < copied.bins; k++) {
        int d = abs(refreshed.droop_q8[k] - rebuilt.droop_q8[k]);
        worst = d > worst ? d : worst;
        grew += refreshed.droop_q8[k] >= copied.droop_q8[k] + 3;
    }
    print_message("refreshed against rebuilt: worst %d/256 code per unit\n", worst);
    assert_true(worst <= 1); /* the refresh and the build invert two grids of their own */
    print_message("margin +%.3g s: %d of %u bins' droop grew by >= 3/256 code per unit\n", added, grew, copied.bins);
    assert_true(grew > (int)copied.bins / 2);
    free(lut);
    free(ext);
}

int main(void)
{
    const struct CMUnitTest tests[] = {cmocka_unit_test(droop_follows_the_margin)};
    return cmocka_run_group_tests(tests, NULL, NULL);
}
