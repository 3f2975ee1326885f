/* The Linux board's description: JSON (cJSON) to lx_board, every field checked, every error
 * naming the file, the field and the value. Pure: it touches no device (fuzz target
 * tests/fuzz/fuzz_linux_board.c). */
#include "hal_linux_board.h"
#include <cjson/cJSON.h>
#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define FORMAT "wdrcam-linux-board"
#define MAX_OFFSET 65535.0 /* the uAPI's offsets are u32; no chip has more lines than this */

typedef struct ctx {
    const char *file;
    char *err;
    size_t errlen;
} ctx;

static const char *const fixed_roles[3] = {"reset", "row_select", "adc_convert"};

const char *lx_line_role(unsigned i, char *buf, size_t cap)
{
    if (i < 3)
        snprintf(buf, cap, "%s", fixed_roles[i]);
    else
        snprintf(buf, cap, "row_address[%u]", i - 3);
    return buf;
}

/* The item's value as text for a message: numbers as given, strings quoted, others by kind. */
static void value_text(const cJSON *v, char *out, size_t cap)
{
    if (!v)
        snprintf(out, cap, "(missing)");
    else if (cJSON_IsNumber(v))
        snprintf(out, cap, "%.17g", v->valuedouble);
    else if (cJSON_IsString(v))
        snprintf(out, cap, "\"%.60s%s\"", v->valuestring, strlen(v->valuestring) > 60 ? "..." : "");
    else
        snprintf(out, cap, "%s", cJSON_IsBool(v) ? "a boolean" : cJSON_IsNull(v) ? "null" : cJSON_IsArray(v) ? "an array"
                                                                                              : "an object");
}

static int bad(const ctx *c, const char *field, const cJSON *v, const char *fmt, ...)
{
    char why[160], val[96];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(why, sizeof why, fmt, ap);
    va_end(ap);
    value_text(v, val, sizeof val);
    snprintf(c->err, c->errlen, "%s: field '%s': value %s: %s", c->file, field, val, why);
    return -1;
}

static void join(char *out, size_t cap, const char *section, const char *key)
{
    snprintf(out, cap, "%s%s%s", section ? section : "", section ? "." : "", key);
}

/* Every key of obj must be one of `known` (NULL-terminated). */
static int only_known(const ctx *c, const cJSON *obj, const char *section, const char *const *known)
{
    for (const cJSON *it = obj->child; it; it = it->next) {
        const char *const *k = known;
        while (*k && strcmp(*k, it->string))
            k++;
        if (!*k) {
            char f[96];
            join(f, sizeof f, section, it->string);
            return bad(c, f, it, "unknown field");
        }
    }
    return 0;
}

static const cJSON *section_of(const ctx *c, const cJSON *root, const char *name, const char *const *known)
{
    const cJSON *s = cJSON_GetObjectItemCaseSensitive(root, name);
    if (!cJSON_IsObject(s)) {
        bad(c, name, s, "must be an object");
        return NULL;
    }
    return only_known(c, s, name, known) == 0 ? s : NULL;
}

/* An integer field in [lo, hi]; absent takes dflt, unless dflt < 0 (required). */
static int get_uint(const ctx *c, const cJSON *obj, const char *section, const char *key, double lo, double hi,
                    double dflt, uint32_t *out)
{
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(obj, key);
    char f[96];
    join(f, sizeof f, section, key);
    if (!v && dflt >= 0) {
        *out = (uint32_t)dflt;
        return 0;
    }
    if (!v || !cJSON_IsNumber(v))
        return bad(c, f, v, v ? "must be a number" : "is required");
    double d = v->valuedouble;
    if (!isfinite(d) || d != floor(d) || d < lo || d > hi)
        return bad(c, f, v, "must be an integer in %.0f..%.0f", lo, hi);
    *out = (uint32_t)d;
    return 0;
}

/* A string field of 1..cap-1 bytes; must_be_path: it starts with '/'. */
static int get_string(const ctx *c, const cJSON *obj, const char *section, const char *key, int must_be_path,
                      char *out, size_t cap)
{
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(obj, key);
    char f[96];
    join(f, sizeof f, section, key);
    if (!v || !cJSON_IsString(v))
        return bad(c, f, v, v ? "must be a string" : "is required");
    size_t n = strlen(v->valuestring);
    if (n == 0 || n >= cap)
        return bad(c, f, v, "must be 1..%zu characters", cap - 1);
    if (must_be_path && v->valuestring[0] != '/')
        return bad(c, f, v, "must be an absolute path");
    memcpy(out, v->valuestring, n + 1);
    return 0;
}

static int parse_sensor(const ctx *c, const cJSON *root, lx_board *b)
{
    static const char *const known[] = {"id", "width", "height", "adc_bits", "dac_bits", "row_time_ns",
                                        "adc_convert_ns", NULL};
    const cJSON *s = section_of(c, root, "sensor", known);
    uint32_t w = 0, h = 0, ab = 0, db = 0;
    if (!s || get_uint(c, s, "sensor", "id", 0, 4294967295.0, 13569, &b->sensor_id) ||
        get_uint(c, s, "sensor", "width", 1, HAL_LINUX_MAX_WIDTH, -1, &w) ||
        get_uint(c, s, "sensor", "height", 1, 65535, -1, &h) || get_uint(c, s, "sensor", "adc_bits", 4, 16, -1, &ab) ||
        get_uint(c, s, "sensor", "dac_bits", 4, 16, -1, &db) ||
        get_uint(c, s, "sensor", "row_time_ns", 1, 1e9, 20000, &b->row_time_ns) ||
        get_uint(c, s, "sensor", "adc_convert_ns", 0, 1e8, 2000, &b->adc_convert_ns))
        return -1;
    b->width = (uint16_t)w;
    b->height = (uint16_t)h;
    b->adc_bits = (uint8_t)ab;
    b->dac_bits = (uint8_t)db;
    return 0;
}

/* A line: an offset on the chip, or its name. */
static int parse_line(const ctx *c, const cJSON *v, const char *field, lx_line_ref *out)
{
    if (cJSON_IsNumber(v)) {
        double d = v->valuedouble;
        if (!isfinite(d) || d != floor(d) || d < 0 || d > MAX_OFFSET)
            return bad(c, field, v, "a line offset must be an integer in 0..%.0f", MAX_OFFSET);
        out->offset = (int)d;
        out->name[0] = 0;
        return 0;
    }
    if (cJSON_IsString(v) && v->valuestring[0] && strlen(v->valuestring) < sizeof out->name) {
        out->offset = -1;
        memcpy(out->name, v->valuestring, strlen(v->valuestring) + 1);
        return 0;
    }
    return bad(c, field, v, v ? "must be a line offset or a line name of 1..%zu characters" : "is required",
               sizeof out->name - 1);
}

static int same_line(const lx_line_ref *a, const lx_line_ref *b)
{
    return a->offset >= 0 ? a->offset == b->offset : b->offset < 0 && !strcmp(a->name, b->name);
}

static int parse_gpio(const ctx *c, const cJSON *root, lx_board *b)
{
    static const char *const known[] = {"chip", "reset", "row_select", "adc_convert", "row_address", NULL};
    const cJSON *g = section_of(c, root, "gpio", known);
    char f[96];
    if (!g || get_string(c, g, "gpio", "chip", 0, b->gpio_chip, sizeof b->gpio_chip))
        return -1;
    for (unsigned i = 0; i < 3; i++) {
        join(f, sizeof f, "gpio", fixed_roles[i]);
        if (parse_line(c, cJSON_GetObjectItemCaseSensitive(g, fixed_roles[i]), f, &b->lines[i]))
            return -1;
    }
    const cJSON *addr = cJSON_GetObjectItemCaseSensitive(g, "row_address");
    int n = cJSON_IsArray(addr) ? cJSON_GetArraySize(addr) : -1;
    if (n < 1 || n > (int)HAL_LINUX_MAX_ROW_ADDR_BITS)
        return bad(c, "gpio.row_address", addr, "must be an array of 1..%u lines, bit 0 first",
                   HAL_LINUX_MAX_ROW_ADDR_BITS);
    if ((1ul << n) < b->height)
        return bad(c, "gpio.row_address", addr, "%d address lines cannot address %u rows (sensor.height)", n,
                   b->height);
    for (int i = 0; i < n; i++) {
        snprintf(f, sizeof f, "gpio.row_address[%d]", i);
        if (parse_line(c, cJSON_GetArrayItem(addr, i), f, &b->lines[3 + i]))
            return -1;
    }
    b->n_lines = 3u + (unsigned)n;
    for (unsigned i = 0; i < b->n_lines; i++)
        for (unsigned j = 0; j < i; j++)
            if (same_line(&b->lines[i], &b->lines[j])) {
                char ri[32], rj[32];
                lx_line_role(i, ri, sizeof ri);
                snprintf(f, sizeof f, "gpio.%s", ri);
                const cJSON *v = i < 3 ? cJSON_GetObjectItemCaseSensitive(g, ri) : cJSON_GetArrayItem(addr, (int)i - 3);
                return bad(c, f, v, "the same line as gpio.%s", lx_line_role(j, rj, sizeof rj));
            }
    return 0;
}

static int parse_spi_device(const ctx *c, const cJSON *spi, const char *key, lx_spi_ref *out)
{
    static const char *const known[] = {"device", "speed_hz", NULL};
    char section[16];
    snprintf(section, sizeof section, "spi.%s", key);
    const cJSON *d = cJSON_GetObjectItemCaseSensitive(spi, key);
    if (!cJSON_IsObject(d))
        return bad(c, section, d, "must be an object {\"device\": \"/dev/spidevB.C\", \"speed_hz\": N}");
    if (only_known(c, d, section, known) || get_string(c, d, section, "device", 1, out->path, sizeof out->path))
        return -1;
    return get_uint(c, d, section, "speed_hz", 1000, 200e6, 20e6, &out->speed_hz);
}

static int parse_devices(const ctx *c, const cJSON *root, lx_board *b)
{
    static const char *const spi_known[] = {"dac", "adc", NULL};
    static const char *const flash_known[] = {"mtd", NULL};
    static const char *const usb_known[] = {"functionfs", NULL};
    const cJSON *spi = section_of(c, root, "spi", spi_known);
    if (!spi || parse_spi_device(c, spi, "dac", &b->dac) || parse_spi_device(c, spi, "adc", &b->adc))
        return -1;
    if (!strcmp(b->dac.path, b->adc.path))
        return bad(c, "spi.adc.device", cJSON_GetObjectItemCaseSensitive(cJSON_GetObjectItemCaseSensitive(spi, "adc"), "device"),
                   "the same device as spi.dac.device");
    const cJSON *flash = section_of(c, root, "flash", flash_known);
    if (!flash || get_string(c, flash, "flash", "mtd", 0, b->mtd, sizeof b->mtd))
        return -1;
    const cJSON *usb = section_of(c, root, "usb", usb_known);
    return !usb ? -1 : get_string(c, usb, "usb", "functionfs", 1, b->functionfs, sizeof b->functionfs);
}

static int parse_root(const ctx *c, const cJSON *root, lx_board *b)
{
    static const char *const known[] = {"format", "version", "name", "comment", "sensor", "gpio",
                                        "spi", "flash", "usb", NULL};
    if (!cJSON_IsObject(root))
        return bad(c, "(top level)", root, "a board file is one JSON object");
    if (only_known(c, root, NULL, known))
        return -1;
    const cJSON *format = cJSON_GetObjectItemCaseSensitive(root, "format");
    if (!cJSON_IsString(format) || strcmp(format->valuestring, FORMAT))
        return bad(c, "format", format, "must be \"" FORMAT "\"");
    uint32_t version;
    if (get_uint(c, root, NULL, "version", 1, 1, -1, &version))
        return -1;
    const cJSON *comment = cJSON_GetObjectItemCaseSensitive(root, "comment");
    if (comment && !cJSON_IsString(comment))
        return bad(c, "comment", comment, "must be a string");
    return get_string(c, root, NULL, "name", 0, b->name, sizeof b->name) || parse_sensor(c, root, b) ||
                   parse_gpio(c, root, b) || parse_devices(c, root, b)
               ? -1
               : 0;
}

int lx_board_parse(const char *text, size_t len, const char *file, lx_board *out, char *err, size_t errlen)
{
    ctx c = {file, err, errlen};
    memset(out, 0, sizeof *out);
    err[0] = 0;
    const char *end = NULL;
    cJSON *root = cJSON_ParseWithLengthOpts(text, len, &end, 0);
    if (!root) {
        size_t at = end && end >= text ? (size_t)(end - text) : 0;
        snprintf(err, errlen, "%s: not valid JSON near byte %zu", file, at);
        return -1;
    }
    int rc = parse_root(&c, root, out);
    cJSON_Delete(root);
    return rc;
}

int lx_board_load(const char *file, lx_board *out, char *err, size_t errlen)
{
    FILE *f = fopen(file, "rb");
    if (!f) {
        snprintf(err, errlen, "%s: %s", file, strerror(errno));
        return -2;
    }
    static char text[HAL_LINUX_BOARD_FILE_MAX + 1];
    size_t n = fread(text, 1, sizeof text, f);
    int read_error = ferror(f);
    fclose(f);
    if (read_error || n > HAL_LINUX_BOARD_FILE_MAX) {
        snprintf(err, errlen, "%s: %s", file, read_error ? "read error" : "larger than 64 KiB: not a board file");
        return read_error ? -2 : -1;
    }
    return lx_board_parse(text, n, file, out, err, errlen);
}
