#include "crc32.h"
#include "crc32_table.h"

/* Slice-by-4: four table look-ups per 32-bit word. Every streamed row carries a CRC, so this
 * sits on the readout path; 4 KiB of flash buys about 4x over a byte-wise table. */
uint32_t wdr_crc32(uint32_t crc, const void *data, size_t len)
{
    const uint8_t *p = data;
    crc = ~crc;
    for (; len >= 4; len -= 4, p += 4) {
        crc ^= (uint32_t)p[0] | ((uint32_t)p[1] << 8) | ((uint32_t)p[2] << 16) | ((uint32_t)p[3] << 24);
        crc = crc32_slice[3][crc & 0xff] ^ crc32_slice[2][(crc >> 8) & 0xff] ^ crc32_slice[1][(crc >> 16) & 0xff] ^
              crc32_slice[0][crc >> 24];
    }
    while (len--)
        crc = (crc >> 8) ^ crc32_slice[0][(crc ^ *p++) & 0xff];
    return ~crc;
}
