/* Little-endian fields of the table formats and the wire protocol (firmware/SPEC.md), read and
 * written byte by byte: correct on any host and for unaligned fields. */
#ifndef WDR_BYTES_H
#define WDR_BYTES_H
#include <stdint.h>

uint16_t wdr_get_u16(const uint8_t *p);
uint32_t wdr_get_u32(const uint8_t *p);
float wdr_get_f32(const uint8_t *p);
void wdr_put_u16(uint8_t *p, uint16_t v);
void wdr_put_u32(uint8_t *p, uint32_t v);
void wdr_put_f32(uint8_t *p, float v);

#endif
