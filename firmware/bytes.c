/* Little-endian field access (see wdr_bytes.h). */
#include "wdr_bytes.h"
#include <string.h>

uint16_t wdr_get_u16(const uint8_t *p) { return (uint16_t)(p[0] | (p[1] << 8)); }

uint32_t wdr_get_u32(const uint8_t *p)
{
    return (uint32_t)p[0] | ((uint32_t)p[1] << 8) | ((uint32_t)p[2] << 16) | ((uint32_t)p[3] << 24);
}

float wdr_get_f32(const uint8_t *p)
{
    uint32_t u = wdr_get_u32(p);
    float f;
    memcpy(&f, &u, sizeof f);
    return f;
}

void wdr_put_u16(uint8_t *p, uint16_t v)
{
    p[0] = (uint8_t)v;
    p[1] = (uint8_t)(v >> 8);
}

void wdr_put_u32(uint8_t *p, uint32_t v)
{
    for (int i = 0; i < 4; i++)
        p[i] = (uint8_t)(v >> (8 * i));
}

void wdr_put_f32(uint8_t *p, float v)
{
    uint32_t u;
    memcpy(&u, &v, sizeof u);
    wdr_put_u32(p, u);
}
