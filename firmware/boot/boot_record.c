/* The boot record the bootloader leaves in RAM for the application: a CRC-32 over its bytes.
 * The writer zeroes the whole struct first (memset), so its padding bytes are part of what
 * the CRC covers and stay the same when the application reads them. */
#include "crc32.h"
#include "wdr_boot.h"
#include <stddef.h>

static uint32_t record_crc(const wdr_boot_record *r) { return wdr_crc32(0, r, offsetof(wdr_boot_record, crc)); }

void wdr_boot_record_seal(wdr_boot_record *r)
{
    r->magic = WDR_BOOT_RECORD_MAGIC_RAM;
    r->crc = record_crc(r);
}

bool wdr_boot_record_ok(const wdr_boot_record *r)
{
    return r->magic == WDR_BOOT_RECORD_MAGIC_RAM && r->crc == record_crc(r);
}
