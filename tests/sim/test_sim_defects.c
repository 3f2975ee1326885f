/* The "defects" effect: planted pixels at known positions and rates behave by their physics.
 * A dead pixel's code does not follow the light, a hot pixel in the dark reads as a lit one,
 * a stuck pixel holds one code at every light, a saturated one sits at the ADC's top rail;
 * healthy pixels are bit-identical with the effect on or off; auto says why it ran or not. */
#include "sim_test.h"
#include "wdr_scene.h"
#include <unistd.h>

#define W 64
#define H 32
#define NP (W * H)

static void render(wdr_sim *s, double amps, uint16_t *out)
{
    assert_int_equal(wdr_sim_set_uniform(s, amps), WDR_OK);
    assert_int_equal(wdr_sim_render(s, 7, out), WDR_OK);
}

static void defects_behave_by_physics(void **state)
{
    (void)state;
    wdr_board b;
    test_chip tc;
    test_board(&b, W, H);
    test_chip_open(&tc, &b, "reinhard", 3);
    long idx[4] = {5, W + 9, 2 * W + 17, NP - 1};
    uint8_t kind[4] = {WDR_DEFECT_DEAD, WDR_DEFECT_HOT, WDR_DEFECT_STUCK, WDR_DEFECT_SATURATED};
    wdr_sim_defects d = {.ppm = {0, 1000, 1000, 1000, 1000}, .n_listed = 4, .listed_index = idx, .listed_kind = kind};
    assert_int_equal(wdr_sim_set_defects(tc.s, &d), WDR_OK);
    /* 1000 ppm of 2048 pixels: 2 of each kind drawn, plus the 4 listed (they may override one) */
    long n = wdr_sim_defect_count(tc.s, WDR_DEFECT_NONE);
    assert_true(n >= 8 && n <= 12);
    uint8_t map[NP];
    wdr_sim_defect_map(tc.s, map);
    for (int j = 0; j < 4; j++)
        assert_int_equal(map[idx[j]], kind[j]);
    uint16_t dark[NP], lit[NP], bright[NP], off[NP];
    render(tc.s, 1e-15, dark);
    render(tc.s, 1e-11, lit);
    render(tc.s, 1e-8, bright);
    assert_true(abs((int)dark[idx[0]] - (int)bright[idx[0]]) <= 2); /* dead: no current, no response */
    assert_true(dark[5 + 1] - bright[5 + 1] > 1000);                /* its healthy neighbour responds */
    assert_true(dark[idx[1]] + 500 < dark[W + 10]);                 /* hot: lit in the dark */
    assert_true(abs((int)dark[idx[2]] - (int)bright[idx[2]]) <= 2); /* stuck: one code at every light */
    assert_int_equal(bright[idx[3]], 4095);                         /* saturated: the top rail */
    assert_int_equal(dark[idx[3]], 4095);
    /* healthy pixels: the same bits with the effect off */
    wdr_sim_set_effect(tc.s, WDR_FX_DEFECTS, WDR_FX_OFF);
    render(tc.s, 1e-11, off);
    for (long i = 0; i < NP; i++)
        if (!map[i])
            assert_int_equal(off[i], lit[i]);
    assert_true(off[idx[3]] != 4095);
    /* auto: runs with planted pixels and says so; skips without */
    wdr_sim_set_effect(tc.s, WDR_FX_DEFECTS, WDR_FX_AUTO);
    render(tc.s, 1e-11, off);
    const wdr_fx_report *r = &wdr_sim_report(tc.s)[WDR_FX_DEFECTS];
    assert_true(r->ran);
    assert_non_null(strstr(r->why, "defective pixels planted"));
    assert_int_equal(wdr_sim_set_defects(tc.s, NULL), WDR_OK);
    render(tc.s, 1e-11, off);
    r = &wdr_sim_report(tc.s)[WDR_FX_DEFECTS];
    assert_false(r->ran);
    assert_non_null(strstr(r->why, "no defective pixels"));
    /* bad requests */
    wdr_sim_defects bad = {.ppm = {0, -1}};
    assert_int_equal(wdr_sim_set_defects(tc.s, &bad), WDR_E_INVAL);
    long far = NP;
    uint8_t dead = WDR_DEFECT_DEAD;
    wdr_sim_defects out_of_range = {.n_listed = 1, .listed_index = &far, .listed_kind = &dead};
    assert_int_equal(wdr_sim_set_defects(tc.s, &out_of_range), WDR_E_INVAL);
    test_chip_close(&tc);
}

static char dir[64];

/* Scene files in a fresh /tmp/wdr_* folder, removed at the end. */
static const char *in_dir(const char *name)
{
    static char path[128];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    return path;
}

static void write_file(const char *name, const char *text)
{
    FILE *f = fopen(in_dir(name), "w");
    assert_non_null(f);
    fputs(text, f);
    fclose(f);
}

static void scene_defects_parsed_and_checked(void **state)
{
    (void)state;
    wdr_board b;
    wdr_scene sc;
    char err[512];
    test_board(&b, W, H);
    snprintf(dir, sizeof dir, "/tmp/wdr_defects_XXXXXX");
    assert_non_null(mkdtemp(dir));
    write_file("defects_ok.json", "{\"format\": \"wdrcam-scene\", \"version\": 1,"
                                  " \"illumination\": {\"pattern\": \"uniform\"},"
                                  " \"defects\": {\"hot_ppm\": 1000, \"hot_A\": 2e-11,"
                                  " \"pixels\": [{\"x\": 3, \"y\": 2, \"kind\": \"stuck\"}]}}");
    assert_int_equal(wdr_scene_load(in_dir("defects_ok.json"), &b, &sc, err, sizeof err), WDR_OK);
    assert_true(sc.has_defects);
    assert_int_equal(sc.defects.n_listed, 1);
    assert_int_equal(sc.defects.listed_index[0], 2 * W + 3);
    assert_int_equal(sc.defects.listed_kind[0], WDR_DEFECT_STUCK);
    assert_near(sc.defects.hot_amps, 2e-11, 0);
    wdr_sim *s = wdr_sim_create(&b, 1);
    assert_int_equal(wdr_scene_apply(&sc, s), WDR_OK);
    assert_int_equal(wdr_sim_defect_count(s, WDR_DEFECT_HOT), 2);
    assert_int_equal(wdr_sim_defect_count(s, WDR_DEFECT_STUCK), 1);
    wdr_sim_destroy(s);
    wdr_scene_free(&sc);
    write_file("defects_bad.json", "{\"format\": \"wdrcam-scene\", \"version\": 1,"
                                   " \"illumination\": {\"pattern\": \"uniform\"},"
                                   " \"defects\": {\"pixels\": [{\"x\": 3, \"y\": 2, \"kind\": \"melted\"}]}}");
    assert_int_equal(wdr_scene_load(in_dir("defects_bad.json"), &b, &sc, err, sizeof err), WDR_E_INVAL);
    assert_non_null(strstr(err, "defects.pixels[0]"));
    assert_non_null(strstr(err, "melted"));
    wdr_scene_free(&sc);
    write_file("defects_typo.json", "{\"format\": \"wdrcam-scene\", \"version\": 1,"
                                    " \"illumination\": {\"pattern\": \"uniform\"}, \"defects\": {\"ded_ppm\": 3}}");
    assert_int_equal(wdr_scene_load(in_dir("defects_typo.json"), &b, &sc, err, sizeof err), WDR_E_INVAL);
    assert_non_null(strstr(err, "defects.ded_ppm"));
    wdr_scene_free(&sc);
    const char *names[] = {"defects_ok.json", "defects_bad.json", "defects_typo.json"};
    for (int k = 0; k < 3; k++)
        remove(in_dir(names[k]));
    rmdir(dir);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(defects_behave_by_physics),
        cmocka_unit_test(scene_defects_parsed_and_checked),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
