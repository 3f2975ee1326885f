/* Tables live in flash: a LUT and a calibration table uploaded to one wdr-simboard run are
 * active after a restart on the same flash file, with no upload, and give the same frame. */
#include "e2e_board.h"
#include "crc32.h"
#include "wdr_cal.h"
#include "wdr_err.h"
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <cmocka.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

static char flash_dir[64], flash_path[128];

static void kept_across_restart(void **state)
{
    (void)state;
    e2e_board rig;
    uint8_t *lut;
    size_t lut_len;
    wdr_commit_reply reply;
    wdr_status_report first, second;
    snprintf(flash_dir, sizeof flash_dir, "/tmp/wdr-flash-XXXXXX");
    assert_non_null(mkdtemp(flash_dir));
    snprintf(flash_path, sizeof flash_path, "%s/flash.bin", flash_dir);

    assert_int_equal(e2e_start_with_flash(&rig, "sim-qvga", flash_path), 0);
    size_t n = (size_t)rig.board.width * rig.board.height;
    uint16_t *a = malloc(n * sizeof *a), *b = malloc(n * sizeof *b);
    assert_int_equal(e2e_reinhard_lut(&rig.board, &lut, &lut_len), WDR_OK);
    assert_int_equal(wdr_client_capture(rig.c, 1, a, NULL, NULL), WDR_E_STATUS); /* factory-new: no LUT */
    assert_int_equal(rig.c->status, WDR_ST_NO_TABLE);
    assert_int_equal(wdr_client_upload(rig.c, WDR_KIND_LUT, lut, lut_len, NULL, NULL, &reply), WDR_OK);
    assert_int_equal(wdr_client_capture(rig.c, 1, a, NULL, NULL), WDR_OK);
    assert_int_equal(wdr_client_status(rig.c, &first), WDR_OK);
    e2e_stop(&rig);

    assert_int_equal(e2e_start_with_flash(&rig, "sim-qvga", flash_path), 0);
    assert_int_equal(wdr_client_status(rig.c, &second), WDR_OK);
    assert_int_equal(second.lut_slot, first.lut_slot);
    assert_int_equal(second.lut_crc, wdr_crc32(0, lut, lut_len));
    assert_int_equal(second.frames, 0); /* a new boot */
    assert_int_equal(wdr_client_capture(rig.c, 1, b, NULL, NULL), WDR_OK);
    assert_memory_equal(a, b, n * sizeof *a);
    e2e_stop(&rig);

    free(a);
    free(b);
    free(lut);
    unlink(flash_path);
    rmdir(flash_dir);
}

int main(void)
{
    const struct CMUnitTest tests[] = {cmocka_unit_test(kept_across_restart)};
    return cmocka_run_group_tests(tests, NULL, NULL);
}
