/* Bad scene files: each case fails with a negative code and a message that names the file and
 * the field (and the value where there is one). Negative pixels are clamped with a warning. */
#include "image_io.h"
#include "sim_test.h"
#include "wdr_scene.h"
#include <unistd.h>

#define W 8
#define H 4

static char dir[64];

typedef struct bad_case {
    const char *json;
    int rc;
    const char *field, *value; /* both must appear in the message */
} bad_case;

static const bad_case cases[] = {
    {"{ \"illumination\": { \"image\": \"nope.exr\" } }", WDR_E_IO, "illumination.image", "nope.exr"},
    {"{ \"illumination\": { \"image\": \"nan.pfm\" } }", WDR_E_INVAL, "illumination.image", "nan"},
    {"{ \"illumination\": { \"image\": \"inf.pfm\" } }", WDR_E_INVAL, "illumination.image", "inf"},
    {"{ \"illumination\": { \"image\": \"big.pfm\", \"fit\": \"exact\" } }", WDR_E_GEOMETRY, "illumination.image", "16x8"},
    {"{ \"size\": [9, 4], \"illumination\": { \"pattern\": \"uniform\" } }", WDR_E_GEOMETRY, "size", "9"},
    {"{ \"size\": \"8x4\", \"illumination\": { \"pattern\": \"uniform\" } }", WDR_E_INVAL, "size", "[width, height]"},
    {"{ \"illumination\": { \"pattern\": \"uniform\" }, \"effects\": { \"bogus\": \"on\" } }", WDR_E_INVAL,
     "effects.bogus", "unknown effect"},
    {"{ \"illumination\": { \"pattern\": \"uniform\" }, \"effects\": { \"shot\": \"sometimes\" } }", WDR_E_INVAL,
     "effects.shot", "sometimes"},
    {"{ \"illumination\": { \"pattern\": \"uniform\" }, \"effects\": { \"shot\": true } }", WDR_E_INVAL,
     "effects.shot", "not a string"},
    {"{ \"illumination\": { \"pattern\": \"uniform\" }, \"exposure\": -1 }", WDR_E_INVAL, "exposure", "-1"},
    {"{ \"illumination\": { \"pattern\": \"uniform\" }, \"lum_to_amp\": 0 }", WDR_E_INVAL, "lum_to_amp", "0"},
    {"{ \"illumination\": { \"pattern\": \"uniform\" }, \"exposure\": 1e9 }", WDR_E_INVAL, "exposure", "A"},
    {"{ \"illumination\": { \"pattern\": \"log_wedge\", \"l_min\": 10, \"l_max\": 1 } }", WDR_E_INVAL,
     "illumination.l_max", "1"},
    {"{ \"illumination\": { \"pattern\": \"log_wedge\", \"l_min\": -1 } }", WDR_E_INVAL, "illumination.l_min", "-1"},
    {"{ \"illumination\": { \"pattern\": \"spiral\" } }", WDR_E_INVAL, "illumination.pattern", "spiral"},
    {"{ \"illumination\": { \"pattern\": \"window\", \"window\": [0.5, 0.1, 1.5, 0.6] } }", WDR_E_INVAL,
     "illumination.window", "fraction"},
    {"{ \"illumination\": { \"pattern\": \"uniform\", \"colour\": 3 } }", WDR_E_INVAL, "illumination.colour",
     "unknown field"},
    {"{ \"illumination\": { \"pattern\": \"uniform\", \"image\": \"a.pfm\" } }", WDR_E_INVAL, "illumination",
     "exactly one"},
    {"{ \"effects\": {} }", WDR_E_INVAL, "illumination", "missing"},
    {"{ \"illumination\": { \"pattern\": \"uniform\" }, \"exposur\": 2 }", WDR_E_INVAL, "exposur", "unknown field"},
    {"{ \"illumination\": { \"pattern\": \"uniform\" }, \"auto_tolerance_lsb\": -0.1 }", WDR_E_INVAL,
     "auto_tolerance_lsb", "-0.1"},
    {"{ \"illumination\": { \"pattern\": \"uniform\" }, \"chip_seed\": 1.5 }", WDR_E_INVAL, "chip_seed", "1.5"},
    {"{ \"illumination\": { \"pattern\": \"uniform\" }, \"reference\": \"yes\" }", WDR_E_INVAL, "reference",
     "true or false"},
    {"{ \"illumination\": { \"image\": \"big.pfm\", \"fit\": \"squash\" } }", WDR_E_INVAL, "illumination.fit",
     "resample"},
    {"{ \"format\": \"wdrcam-board\", \"illumination\": { \"pattern\": \"uniform\" } }", WDR_E_INVAL, "format",
     "wdrcam-board"},
    {"{ \"illumination\": ", WDR_E_INVAL, "(top level)", "not a JSON object"},
};

static void write_text(const char *path, const char *text)
{
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    fputs(text, f);
    fclose(f);
}

static void write_pfm(const char *name, int w, int h, float special)
{
    char path[128], err[256];
    float *px = malloc((size_t)w * h * sizeof *px);
    for (int i = 0; i < w * h; i++)
        px[i] = 5.0f;
    px[w + 2] = special; /* pixel (2, 1) */
    snprintf(path, sizeof path, "%s/%s", dir, name);
    assert_int_equal(wdr_pfm_write(path, px, w, h, err, sizeof err), WDR_OK);
    free(px);
}

static int load_text(const char *json, wdr_scene *sc, char *path, char *err, int errlen)
{
    wdr_board b;
    test_board(&b, W, H);
    snprintf(path, 128, "%s/scene.json", dir);
    write_text(path, json);
    return wdr_scene_load(path, &b, sc, err, errlen);
}

static void every_bad_case_names_file_and_field(void **state)
{
    (void)state;
    for (size_t k = 0; k < sizeof cases / sizeof cases[0]; k++) {
        wdr_scene sc;
        char path[128], err[1024] = "", field[160];
        int rc = load_text(cases[k].json, &sc, path, err, sizeof err);
        printf("case %zu: rc %d: %s\n", k, rc, err);
        snprintf(field, sizeof field, "'%s'", cases[k].field);
        assert_int_equal(rc, cases[k].rc);
        assert_non_null(strstr(err, path));
        assert_non_null(strstr(err, field));
        assert_non_null(strstr(err, cases[k].value));
        assert_null(sc.amps);
    }
}

static void missing_scene_file(void **state)
{
    (void)state;
    wdr_board b;
    wdr_scene sc;
    char err[512];
    test_board(&b, W, H);
    assert_int_equal(wdr_scene_load("/nonexistent/scene.json", &b, &sc, err, sizeof err), WDR_E_IO);
    assert_non_null(strstr(err, "/nonexistent/scene.json"));
}

static void negative_pixels_clamped_with_warning(void **state)
{
    (void)state;
    wdr_scene sc;
    char path[128], err[512];
    assert_int_equal(load_text("{ \"illumination\": { \"image\": \"neg.pfm\" } }", &sc, path, err, sizeof err), WDR_OK);
    printf("warning: %s\n", sc.warning);
    assert_non_null(strstr(sc.warning, "1 negative pixels clamped"));
    assert_true(sc.amps[W + 2] == 0.0f && sc.amps[0] > 0);
    wdr_scene_free(&sc);
}

static void resample_when_asked(void **state)
{
    (void)state;
    wdr_scene sc;
    char path[128], err[512];
    int rc = load_text("{ \"illumination\": { \"image\": \"flat.pfm\", \"fit\": \"resample\" }, \"lum_to_amp\": 1e-12 }",
                       &sc, path, err, sizeof err);
    assert_int_equal(rc, WDR_OK);
    assert_non_null(strstr(sc.warning, "resampled from 16x8 to 8x4"));
    for (int i = 0; i < W * H; i++)
        assert_near(sc.amps[i], 5e-12, 1e-18);
    wdr_scene_free(&sc);
}

static void good_scene_applies(void **state)
{
    (void)state;
    wdr_scene sc;
    char path[128], err[512];
    int rc = load_text("{ \"illumination\": { \"pattern\": \"step_chart\", \"l_min\": 1, \"l_max\": 100, "
                       "\"columns\": 2, \"rows\": 1 }, \"effects\": { \"shot\": \"off\", \"read\": \"on\" }, "
                       "\"reference\": true, \"chip_seed\": 42 }",
                       &sc, path, err, sizeof err);
    assert_int_equal(rc, WDR_OK);
    assert_int_equal(sc.effects[WDR_FX_SHOT], WDR_FX_OFF);
    assert_int_equal(sc.effects[WDR_FX_READ], WDR_FX_ON);
    assert_int_equal(sc.effects[WDR_FX_DARK], WDR_FX_AUTO);
    assert_int_equal(sc.chip_seed, 42);
    assert_near(sc.amps[0], 1e-11, 1e-17);          /* left patch: 1 cd/m2 at the default 1e-11 A per cd/m2 */
    assert_near(sc.amps[W - 1], 1e-9, 1e-15);       /* right patch: 100 cd/m2 */
    wdr_scene_free(&sc);
}

static int make_dir(void **state)
{
    (void)state;
    snprintf(dir, sizeof dir, "/tmp/wdr_scene_XXXXXX");
    if (!mkdtemp(dir))
        return -1;
    write_pfm("nan.pfm", W, H, NAN);
    write_pfm("inf.pfm", W, H, INFINITY);
    write_pfm("neg.pfm", W, H, -0.01f);
    write_pfm("big.pfm", 16, 8, 5.0f);
    write_pfm("flat.pfm", 16, 8, 5.0f);
    return 0;
}

static int remove_dir(void **state)
{
    (void)state;
    const char *files[] = {"nan.pfm", "inf.pfm", "neg.pfm", "big.pfm", "flat.pfm", "scene.json"};
    char path[128];
    for (size_t k = 0; k < sizeof files / sizeof files[0]; k++) {
        snprintf(path, sizeof path, "%s/%s", dir, files[k]);
        unlink(path);
    }
    return rmdir(dir);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(every_bad_case_names_file_and_field),
        cmocka_unit_test(missing_scene_file),
        cmocka_unit_test(negative_pixels_clamped_with_warning),
        cmocka_unit_test(resample_when_asked),
        cmocka_unit_test(good_scene_applies),
    };
    return cmocka_run_group_tests(tests, make_dir, remove_dir);
}
