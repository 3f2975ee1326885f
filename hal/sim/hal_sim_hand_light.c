/* Simulated board, the light of a real one: no HAL_CAP_ILLUMINANT, and a lab light a person sets
 * by hand, read from a file when each integration starts. It lets the tests drive the path a real
 * board takes (`wdrctl calibrate` asks for each level, and judges on what it was given), which
 * the self-lit simulated board never reaches.
 *
 * The file holds one photocurrent in amperes (the uniform light on every pixel), or the word
 * `scene` (the light taken away: the board sees its scene again). A missing or empty file is the
 * scene too. A file that says anything else is a person's mistake the board cannot see: the light
 * stays as it was, and the simulator says so once on stderr. */
#include "hal_sim_internal.h"
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const char *light_path; /* NULL: the board lights itself (HAL_CAP_ILLUMINANT) */
static char last_bad[64];

void hal_sim_hand_light_setup(const char *path)
{
    light_path = path;
    last_bad[0] = 0;
}

int hal_sim_hand_light_on(void) { return light_path != NULL; }

/* What the file says: 1 a current in *amps, 0 the scene, -1 unreadable words (in text). */
static int read_light(char *text, size_t len, double *amps)
{
    FILE *f = fopen(light_path, "r");
    text[0] = 0;
    if (!f)
        return 0;
    size_t n = fread(text, 1, len - 1, f);
    fclose(f);
    text[n] = 0;
    text[strcspn(text, "\r\n")] = 0;
    if (!text[0] || !strcmp(text, "scene"))
        return 0;
    char *end;
    errno = 0;
    *amps = strtod(text, &end);
    return !errno && end != text && !*end && isfinite(*amps) && *amps >= 0 ? 1 : -1;
}

void hal_sim_hand_light_apply(void)
{
    if (!light_path)
        return;
    char text[sizeof last_bad];
    double amps = 0;
    int said = read_light(text, sizeof text, &amps);
    if (said < 0) {
        if (strcmp(text, last_bad))
            fprintf(stderr, "hal_sim: %s: '%s' is neither a current in A nor 'scene'; the light stays as it was\n",
                    light_path, text);
        snprintf(last_bad, sizeof last_bad, "%s", text);
        return;
    }
    last_bad[0] = 0;
    int rc = said ? hal_sim_light_uniform(amps) : hal_restore_scene();
    if (rc != WDR_OK)
        fprintf(stderr, "hal_sim: %s: the light could not be set: %d\n", light_path, rc);
}
