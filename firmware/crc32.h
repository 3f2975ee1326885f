/* CRC-32 (IEEE 802.3, reflected, poly 0xEDB88320): the checksum of every table and packet. */
#ifndef WDR_CRC32_H
#define WDR_CRC32_H
#include <stddef.h>
#include <stdint.h>

/* Continue a CRC over len bytes; start with crc = 0. */
uint32_t wdr_crc32(uint32_t crc, const void *data, size_t len);

#endif
