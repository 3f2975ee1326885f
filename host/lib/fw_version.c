/* Image versions as text: "major.minor.patch[+build]" (see fw_sign.h). */
#include "fw_sign.h"
#include "wdr_err.h"
#include <stdio.h>

/* Decimal digits at *p (no sign, no blanks) up to max; advances *p. */
static int number(const char **p, unsigned long max, unsigned long *out)
{
    const char *s = *p;
    unsigned long v = 0;
    if (*s < '0' || *s > '9')
        return 0;
    for (; *s >= '0' && *s <= '9'; s++) {
        v = v * 10u + (unsigned long)(*s - '0');
        if (v > max)
            return 0;
    }
    *p = s;
    *out = v;
    return 1;
}

int wdr_fw_version_parse(const char *text, wdr_image_version *out)
{
    unsigned long major, minor, patch, build = 0;
    const char *p = text;
    if (!text || !number(&p, 255, &major) || *p++ != '.' || !number(&p, 255, &minor) || *p++ != '.' ||
        !number(&p, 65535, &patch))
        return WDR_E_INVAL;
    if (*p == '+' && (p++, !number(&p, 4294967295ul, &build)))
        return WDR_E_INVAL;
    if (*p)
        return WDR_E_INVAL;
    *out = (wdr_image_version){(uint8_t)major, (uint8_t)minor, (uint16_t)patch, (uint32_t)build};
    return WDR_OK;
}

void wdr_fw_version_format(const wdr_image_version *v, char *out, size_t cap)
{
    if (v->build)
        snprintf(out, cap, "%u.%u.%u+%u", v->major, v->minor, v->patch, (unsigned)v->build);
    else
        snprintf(out, cap, "%u.%u.%u", v->major, v->minor, v->patch);
}
