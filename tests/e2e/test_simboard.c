/* The simulated board's contract, through hal/hal.h and its emulator API, without firmware:
 * virtual time that only waits move, ramp playback ending at t_integration, row reads that see
 * the elapsed virtual time (leakage), strict flash with power cuts and injected failures, the
 * flash file, and the USB endpoints over the socket. */
#include "board.h"
#include "hal.h"
#include "hal_sim_emul.h"
#include "transport.h"
#include "wdr_err.h"
#include "wdr_lut.h"
#include "wdr_sim.h"
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <cmocka.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#define N_ENTRIES 256
#define TICK_PS 1000000u /* 1 us */

static wdr_board board;
static uint8_t lut_bytes[WDR_LUT_HEADER_SIZE + N_ENTRIES * WDR_LUT_ENTRY_SIZE];
static wdr_lut_view lut;
static char dir[64];

/* A straight ramp over the DAC range in 256 us, integration ending at 300 us. */
static void make_lut(int dac_bits)
{
    uint32_t t[N_ENTRIES];
    uint16_t codes[N_ENTRIES];
    for (int i = 0; i < N_ENTRIES; i++) {
        t[i] = (uint32_t)i;
        codes[i] = (uint16_t)((uint32_t)i * ((1u << dac_bits) - 1u) / (N_ENTRIES - 1));
    }
    wdr_lut_header h = {.magic = WDR_LUT_MAGIC, .version_major = WDR_LUT_VERSION_MAJOR, .dac_bits = (uint8_t)dac_bits,
                        .timing = WDR_TIMING_STAMPED, .entry_count = N_ENTRIES, .tick_ps = TICK_PS,
                        .t_integration_ticks = 300, .dac_lo_v = (float)board.dac_lo_v, .dac_hi_v = (float)board.dac_hi_v};
    wdr_lut_encode(&h, t, codes, lut_bytes);
    assert_int_equal(wdr_lut_parse(lut_bytes, sizeof lut_bytes, &lut), WDR_OK);
}

static void quiet_sensor(void)
{
    for (int fx = 0; fx < WDR_FX_COUNT; fx++)
        wdr_sim_set_effect(hal_sim_sensor(), fx, fx == WDR_FX_DAC_QUANT || fx == WDR_FX_ADC_QUANT ? WDR_FX_ON : WDR_FX_OFF);
}

static void start(const char *socket_path, const char *flash_path)
{
    char err[512];
    hal_sim_config cfg = {.board = &board, .seed = 7, .frame_seed = 9, .socket_path = socket_path,
                          .flash_path = flash_path, .flash_block_count = 64};
    assert_int_equal(hal_sim_setup(&cfg, err, sizeof err), WDR_OK);
    assert_int_equal(hal_init(), WDR_OK);
    quiet_sensor();
}

static int group_setup(void **state)
{
    (void)state;
    char path[512], err[512];
    wdr_board_defaults(&board);
    wdr_board_path("sim-qvga", path, sizeof path);
    snprintf(dir, sizeof dir, "/tmp/wdr-simboard-XXXXXX");
    if (wdr_board_load(path, &board, err, sizeof err) != WDR_OK || !mkdtemp(dir))
        return -1;
    return 0;
}

static int group_teardown(void **state)
{
    (void)state;
    char cmd[128];
    snprintf(cmd, sizeof cmd, "rm -rf %s", dir);
    return system(cmd) == 0 ? 0 : -1;
}

static hal_event next_event(void)
{
    hal_event ev = {0};
    hal_wait_for_event();
    assert_int_equal(hal_event_poll(&ev), 1);
    return ev;
}

/* ---- Time and ramp -------------------------------------------------------------------------- */

static void waits_move_virtual_time(void **state)
{
    (void)state;
    start(NULL, NULL);
    assert_int_equal(hal_time_ns(), 0);
    hal_delay_ns(500);
    assert_int_equal(hal_time_ns(), 500);
    hal_timer_arm(1000000000ull); /* one virtual second: no real second passes */
    int64_t t0 = wdr_transport_now_ms();
    hal_event ev = next_event();
    assert_int_equal(ev.type, HAL_EV_TIMER);
    assert_int_equal(hal_time_ns(), 1000000000ull);
    assert_true(wdr_transport_now_ms() - t0 < 500);
    hal_sim_teardown();
}

static void ramp_ends_at_t_integration(void **state)
{
    (void)state;
    start(NULL, NULL);
    make_lut(board.dac_bits);
    hal_set_illuminant(1e-11);
    assert_int_equal(hal_pixel_reset(true), WDR_OK);
    hal_delay_ns(2000);
    assert_int_equal(hal_pixel_reset(false), WDR_OK);
    assert_int_equal(hal_ramp_start(&lut), WDR_OK);
    assert_int_equal(hal_ramp_start(&lut), WDR_E_BUSY);
    assert_int_equal(hal_row_select(0), WDR_OK);
    assert_int_equal(hal_adc_convert(), WDR_E_BUSY);
    hal_event ev = next_event();
    assert_int_equal(ev.type, HAL_EV_RAMP_DONE);
    assert_int_equal(hal_time_ns(), 2000 + 300 * (uint64_t)TICK_PS / 1000);
    uint16_t row[160];
    assert_int_equal(hal_adc_convert(), WDR_OK);
    assert_int_equal(hal_time_ns(), 2000 + 300000 + (uint64_t)(board.row_time_s * 1e9 + 0.5));
    assert_int_equal(hal_adc_read_row(row, board.width), WDR_OK);
    assert_int_equal(hal_adc_read_row(row, board.width - 1), WDR_E_INVAL);
    for (int x = 1; x < board.width; x++)
        assert_int_equal(row[x], row[0]); /* uniform light, no mismatch, no noise */
    assert_int_equal(hal_row_select(board.height), WDR_E_INVAL);
    hal_sim_teardown();
}

static void ramp_checks_dac_bits(void **state)
{
    (void)state;
    start(NULL, NULL);
    make_lut(board.dac_bits - 2);
    assert_int_equal(hal_ramp_start(&lut), WDR_E_GEOMETRY);
    assert_int_equal(hal_ramp_start(NULL), WDR_E_INVAL);
    hal_sim_teardown();
}

/* Expose, then read the same row at once and again a virtual second later. */
static void read_row_at(uint64_t wait_ns, uint16_t *row)
{
    make_lut(board.dac_bits);
    hal_set_illuminant(1e-12);
    assert_int_equal(hal_ramp_start(&lut), WDR_OK);
    assert_int_equal(next_event().type, HAL_EV_RAMP_DONE);
    hal_sim_advance_ns(wait_ns);
    assert_int_equal(hal_row_select(3), WDR_OK);
    assert_int_equal(hal_adc_convert(), WDR_OK);
    assert_int_equal(hal_adc_read_row(row, board.width), WDR_OK);
}

static void row_reads_see_elapsed_time(void **state)
{
    (void)state;
    uint16_t early[160], late[160];
    start(NULL, NULL);
    wdr_sim_set_effect(hal_sim_sensor(), WDR_FX_LEAKAGE, WDR_FX_ON);
    read_row_at(0, early);
    read_row_at(1000000000ull, late);
    /* The hold node droops: the source follower, and the code, fall. */
    assert_true(late[0] < early[0]);
    hal_sim_teardown();
}

static void same_seeds_same_frames(void **state)
{
    (void)state;
    uint16_t a[160], b[160];
    start(NULL, NULL);
    for (int fx = 0; fx < WDR_FX_COUNT; fx++)
        wdr_sim_set_effect(hal_sim_sensor(), fx, WDR_FX_ON);
    read_row_at(0, a);
    hal_sim_teardown();
    start(NULL, NULL);
    for (int fx = 0; fx < WDR_FX_COUNT; fx++)
        wdr_sim_set_effect(hal_sim_sensor(), fx, WDR_FX_ON);
    read_row_at(0, b);
    assert_memory_equal(a, b, sizeof a);
    hal_sim_teardown();
}

/* ---- Flash ------------------------------------------------------------------------------------ */

static void flash_is_strict(void **state)
{
    (void)state;
    hal_flash_geometry g;
    uint8_t buf[256], back[256];
    start(NULL, NULL);
    assert_int_equal(hal_flash_geometry_get(&g), WDR_OK);
    assert_int_equal(g.block_count, 64);
    assert_int_equal(hal_flash_read(0, back, sizeof back), WDR_OK);
    for (size_t i = 0; i < sizeof back; i++)
        assert_int_equal(back[i], 0xFF);
    memset(buf, 0x42, sizeof buf);
    assert_int_equal(hal_flash_prog(1, buf, g.prog_size), WDR_E_INVAL);      /* misaligned */
    assert_int_equal(hal_flash_prog(0, buf, g.prog_size - 1), WDR_E_INVAL);  /* partial unit */
    assert_int_equal(hal_flash_prog(0, buf, g.prog_size), WDR_OK);
    assert_int_equal(hal_flash_prog(0, buf, g.prog_size), WDR_E_IO);         /* twice without erase */
    memset(buf, 0xFF, sizeof buf);
    assert_int_equal(hal_flash_prog(0, buf, g.prog_size), WDR_E_IO);         /* even all ones */
    assert_int_equal(hal_flash_erase(g.block_count), WDR_E_INVAL);
    assert_int_equal(hal_flash_read(g.block_size * g.block_count - 4, back, 8), WDR_E_INVAL);
    assert_int_equal(hal_flash_erase(0), WDR_OK);
    assert_int_equal(hal_flash_prog(0, buf, g.prog_size), WDR_OK);
    assert_int_equal(hal_sim_flash_ops(), 3); /* two programs and an erase; reads and refusals do not count */
    hal_sim_teardown();
}

static void power_cut_tears_and_blocks_until_reboot(void **state)
{
    (void)state;
    hal_flash_geometry g;
    uint8_t buf[256], back[256];
    start(NULL, NULL);
    hal_flash_geometry_get(&g);
    memset(buf, 0x00, sizeof buf);
    hal_sim_cut_power_at(2);
    assert_int_equal(hal_flash_prog(0, buf, g.prog_size), WDR_OK);
    assert_int_equal(hal_flash_prog(g.prog_size, buf, g.prog_size), WDR_E_POWER);
    assert_true(hal_sim_power_lost());
    assert_int_equal(hal_flash_read(0, back, 4), WDR_E_POWER);
    assert_int_equal(hal_flash_erase(0), WDR_E_POWER);
    hal_sim_reboot();
    assert_false(hal_sim_power_lost());
    assert_int_equal(hal_time_ns(), 0);
    assert_int_equal(hal_flash_read(g.prog_size, back, g.prog_size), WDR_OK);
    assert_int_equal(back[0], 0x00);                    /* first half written */
    assert_int_equal(back[g.prog_size - 1], 0xFF);      /* second half never was */
    hal_sim_fail_flash_at(1);
    assert_int_equal(hal_flash_erase(0), WDR_E_IO);
    assert_int_equal(hal_flash_read(0, back, 4), WDR_OK);
    assert_int_equal(back[0], 0x00); /* the failed erase left the block alone */
    hal_sim_teardown();
}

static void flash_file_keeps_bytes(void **state)
{
    (void)state;
    char path[128], err[512];
    uint8_t buf[256], back[256];
    snprintf(path, sizeof path, "%s/flash.bin", dir);
    start(NULL, path);
    memset(buf, 0x5a, sizeof buf);
    assert_int_equal(hal_flash_prog(512, buf, 128), WDR_OK);
    hal_sim_teardown();
    start(NULL, path);
    assert_int_equal(hal_flash_read(512, back, 128), WDR_OK);
    assert_memory_equal(back, buf, 128);
    assert_int_equal(hal_flash_prog(512, buf, 128), WDR_E_IO); /* still programmed after the restart */
    hal_sim_teardown();
    hal_sim_config cfg = {.board = &board, .flash_path = path, .flash_block_count = 32};
    assert_int_equal(hal_sim_setup(&cfg, err, sizeof err), WDR_E_INVAL);
    assert_non_null(strstr(err, "flash.bin"));
}

/* ---- USB over the socket ------------------------------------------------------------------------- */

static void *stop_later(void *arg)
{
    (void)arg;
    usleep(300000);
    hal_sim_request_stop();
    return NULL;
}

static void usb_endpoints_over_socket(void **state)
{
    (void)state;
    char path[128], addr[160], err[320];
    uint8_t buf[64];
    wdr_transport *t;
    snprintf(path, sizeof path, "%s/usb.sock", dir);
    snprintf(addr, sizeof addr, "sim:%s", path);
    start(path, NULL);
    assert_int_equal(hal_usb_write((const uint8_t *)"x", 1), WDR_E_IO); /* no host yet */
    assert_int_equal(wdr_transport_open(addr, &t, err, sizeof err), WDR_OK);
    assert_int_equal(next_event().type, HAL_EV_USB_RESET);
    assert_int_equal(wdr_transport_send(t, "hello", 5, 1000), WDR_OK);
    assert_int_equal(next_event().type, HAL_EV_USB_RX);
    assert_int_equal(hal_usb_read(buf, sizeof buf), 5);
    assert_memory_equal(buf, "hello", 5);
    assert_int_equal(hal_usb_read(buf, sizeof buf), 0);
    assert_int_equal(hal_usb_write((const uint8_t *)"world", 5), WDR_OK);
    assert_int_equal(next_event().type, HAL_EV_USB_TX_DONE);
    assert_int_equal(wdr_transport_recv_exact(t, buf, 5, 1000), WDR_OK);
    assert_memory_equal(buf, "world", 5);
    uint64_t virtual_before = hal_time_ns();
    wdr_transport_close(t);
    assert_int_equal(next_event().type, HAL_EV_USB_RX); /* the read then meets the hang-up */
    assert_int_equal(hal_usb_read(buf, sizeof buf), WDR_E_IO);
    assert_int_equal(next_event().type, HAL_EV_USB_RESET);
    /* Idle: the wait blocks in real time on the socket, leaves virtual time alone, and ends on a stop. */
    pthread_t th;
    pthread_create(&th, NULL, stop_later, NULL);
    int64_t t0 = wdr_transport_now_ms();
    hal_wait_for_event();
    assert_true(wdr_transport_now_ms() - t0 >= 250);
    assert_int_equal(hal_time_ns(), virtual_before);
    pthread_join(th, NULL);
    hal_sim_teardown();
    assert_int_equal(access(path, F_OK), -1); /* the socket path is removed */
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(waits_move_virtual_time),
        cmocka_unit_test(ramp_ends_at_t_integration),
        cmocka_unit_test(ramp_checks_dac_bits),
        cmocka_unit_test(row_reads_see_elapsed_time),
        cmocka_unit_test(same_seeds_same_frames),
        cmocka_unit_test(flash_is_strict),
        cmocka_unit_test(power_cut_tears_and_blocks_until_reboot),
        cmocka_unit_test(flash_file_keeps_bytes),
        cmocka_unit_test(usb_endpoints_over_socket),
    };
    return cmocka_run_group_tests(tests, group_setup, group_teardown);
}
