/* Same seeds, same bits: whatever the thread count, and whether rows come from render or from
 * expose + read_row. Different seeds draw different noise and a different chip. */
#include "sim_test.h"

#define W 96
#define H 40
#define N ((long)W * H)

static void wedge(float *amps)
{
    for (long i = 0; i < N; i++)
        amps[i] = (float)(1e-14 * pow(1e6, (double)(i % W) / (W - 1)));
}

static void render_with(const wdr_board *b, uint64_t chip_seed, uint64_t frame_seed, int threads, uint16_t *out)
{
    test_chip tc;
    float amps[N];
    test_chip_open(&tc, b, "reinhard", chip_seed);
    wedge(amps);
    assert_int_equal(wdr_sim_set_photocurrent(tc.s, amps), WDR_OK);
    wdr_sim_set_threads(tc.s, threads);
    assert_int_equal(wdr_sim_render(tc.s, frame_seed, out), WDR_OK);
    test_chip_close(&tc);
}

static void same_seed_same_bits_any_threads(void **state)
{
    (void)state;
    wdr_board b;
    static uint16_t one[N], two[N], three[N], again[N];
    test_board(&b, W, H);
    render_with(&b, 7, 9, 1, one);
    render_with(&b, 7, 9, 2, two);
    render_with(&b, 7, 9, 3, three);
    render_with(&b, 7, 9, 1, again);
    assert_memory_equal(one, two, sizeof one);
    assert_memory_equal(one, three, sizeof one);
    assert_memory_equal(one, again, sizeof one);
}

static long count_differences(const uint16_t *a, const uint16_t *b)
{
    long n = 0;
    for (long i = 0; i < N; i++)
        n += a[i] != b[i];
    return n;
}

static void other_seeds_differ(void **state)
{
    (void)state;
    wdr_board b;
    static uint16_t base[N], frame2[N], chip2[N];
    test_board(&b, W, H);
    render_with(&b, 7, 9, 2, base);
    render_with(&b, 7, 10, 2, frame2);
    render_with(&b, 8, 9, 2, chip2);
    printf("pixels changed: new frame seed %ld of %ld, new chip seed %ld\n", count_differences(base, frame2), N,
           count_differences(base, chip2));
    assert_true(count_differences(base, frame2) > N / 4);
    assert_true(count_differences(base, chip2) > N / 2);
}

/* The HAL's path: expose, then read each row at its own time, gives render's frame. */
static void read_rows_equal_render(void **state)
{
    (void)state;
    wdr_board b;
    test_chip tc;
    float amps[N];
    static uint16_t frame[N], row[W];
    test_board(&b, W, H);
    test_chip_open(&tc, &b, "reinhard", 5);
    wedge(amps);
    assert_int_equal(wdr_sim_set_photocurrent(tc.s, amps), WDR_OK);
    assert_int_equal(wdr_sim_render(tc.s, 3, frame), WDR_OK);
    assert_int_equal(wdr_sim_read_row(tc.s, 0, 0.0, row), WDR_E_INVAL); /* nothing exposed yet */
    assert_int_equal(wdr_sim_expose(tc.s, 3), WDR_OK);
    for (int r = 0; r < H; r++) {
        assert_int_equal(wdr_sim_read_row(tc.s, r, r * b.row_time_s, row), WDR_OK);
        assert_memory_equal(row, frame + (long)r * W, sizeof row);
    }
    test_chip_close(&tc);
}

static void no_lut_no_frame(void **state)
{
    (void)state;
    wdr_board b;
    static uint16_t frame[16];
    test_board(&b, 4, 4);
    wdr_sim *s = wdr_sim_create(&b, 1);
    assert_int_equal(wdr_sim_render(s, 1, frame), WDR_E_NO_TABLE);
    assert_int_equal(wdr_sim_set_uniform(s, -1.0), WDR_E_INVAL);
    assert_int_equal(wdr_sim_set_uniform(s, NAN), WDR_E_INVAL);
    wdr_sim_destroy(s);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(same_seed_same_bits_any_threads),
        cmocka_unit_test(other_seeds_differ),
        cmocka_unit_test(read_rows_equal_render),
        cmocka_unit_test(no_lut_no_frame),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
