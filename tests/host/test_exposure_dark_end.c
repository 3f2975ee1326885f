/* The exposure table's dark end (host/lib/ramp_exposure.c), which the firmware's auto exposure reads:
 * - from the bin that resolves best to the floor's flat run, every bin resolves 4 codes per ln.
 *   On sim-vga Schlick's ramp holds 2 ln in one bin before a last bin of 0.8 ln; the cut that walked
 *   back from the floor stopped at that last bin, and the 2 ln bin put the key +11 to +49 % off
 *   (dark, step chart, HDR wedge, seeds 1 and 2).
 * - WDR_LUT_EXPO_LINEAR_DARK is set where the nominal code past the floor lies on the line in
 *   current to no light (Schlick on both boards: the cut lies where codes stop resolving, the
 *   pixels still cross), and clear where it does not (Reinhard and Drago: their floor is where
 *   pixels stop crossing in time, 1-8 codes off the line): the firmware reads the dark tail from
 *   the codes' mean only under the flag. */
#include "ramp.h"
#include "wdr_err.h"
#include "wdr_lut.h"
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <cmocka.h>

static wdr_lut_exposure ex;

/* The exposure block of board's LUT for op, built as `wdrctl lut build` builds it. */
static void table_of(const char *board, const char *op)
{
    wdr_board b;
    char path[512], err[256];
    wdr_board_path(board, path, sizeof path);
    wdr_board_defaults(&b);
    assert_int_equal(wdr_board_load(path, &b, err, sizeof err), WDR_OK);
    uint8_t *lut;
    size_t len;
    assert_int_equal(wdr_ramp_board_lut(&b, op, &lut, &len, NULL, err, sizeof err), WDR_OK);
    assert_int_equal(wdr_ramp_lut_append_exposure(&lut, &len, &b, 0.18 * b.i_center_a), WDR_OK);
    wdr_lut_view v;
    assert_int_equal(wdr_lut_parse(lut, len, &v), WDR_OK);
    size_t end = wdr_lut_size(v.h.entry_count);
    assert_int_equal(wdr_lut_exposure_parse(lut + end, len - end, &ex), WDR_OK);
    free(lut);
}

/* Every bin from the best-resolving one to the floor's flat run drops at most 1/4 ln per code. */
static void check_resolves_to_the_floor(const char *board, const char *op)
{
    table_of(board, op);
    uint32_t ceiling = 0, floor = ex.bins - 1u, best;
    while (ceiling + 1u < ex.bins && ex.ln_q8[ceiling + 1u] >= ex.ln_q8[0])
        ceiling++;
    while (floor > 0 && ex.ln_q8[floor - 1u] <= ex.ln_q8[ex.bins - 1u])
        floor--;
    best = ceiling + 1u;
    for (uint32_t k = ceiling + 1u; k < floor; k++)
        best = ex.ln_q8[k] - ex.ln_q8[k + 1u] < ex.ln_q8[best] - ex.ln_q8[best + 1u] ? k : best;
    for (uint32_t k = best; k < floor; k++) {
        int drop = ex.ln_q8[k] - ex.ln_q8[k + 1u];
        if (4 * drop > (256 << ex.code_shift))
            fail_msg("%s %s: bin %u drops %.2f ln over %u codes, before the floor's run at bin %u", board, op, k,
                     drop / 256.0, 1u << ex.code_shift, floor);
    }
    print_message("%s %s: floor's run from bin %u (%.2f ln), best bin %u, linear dark end %s\n", board, op, floor,
                  ex.ln_q8[floor] / 256.0, best, ex.flags & WDR_LUT_EXPO_LINEAR_DARK ? "yes" : "no");
}

static void schlick_resolves_to_its_floor(void **state)
{
    (void)state;
    check_resolves_to_the_floor("sim-qvga", "schlick");
    assert_true(ex.flags & WDR_LUT_EXPO_LINEAR_DARK);
    check_resolves_to_the_floor("sim-vga", "schlick");
    assert_true(ex.flags & WDR_LUT_EXPO_LINEAR_DARK);
}

static void crossing_floors_are_not_linear(void **state)
{
    (void)state;
    check_resolves_to_the_floor("sim-qvga", "reinhard");
    assert_false(ex.flags & WDR_LUT_EXPO_LINEAR_DARK);
    check_resolves_to_the_floor("sim-vga", "drago");
    assert_false(ex.flags & WDR_LUT_EXPO_LINEAR_DARK);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(schlick_resolves_to_its_floor),
        cmocka_unit_test(crossing_floors_are_not_linear),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
