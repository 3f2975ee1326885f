/* What the boot library's files share and nobody else sees: the 16-byte record codec, the walk
 * over one log block, and a chunked read helper. SPEC.md, "Image flash and boot", "Records". */
#ifndef WDR_BOOT_INTERNAL_H
#define WDR_BOOT_INTERNAL_H
#include "wdr_boot.h"
#include <stdbool.h>
#include <stdint.h>

/* Bytes read per flash read while hashing, CRC-ing or walking a log: small, on the stack. */
#define BOOT_READ_CHUNK 256u

enum boot_unit { BOOT_UNIT_ERASED = 0, BOOT_UNIT_RECORD = 1, BOOT_UNIT_TORN = 2 };

void boot_record_encode(uint8_t type, uint32_t value, uint8_t out[WDR_BOOT_RECORD_SIZE]);
/* What a 16-byte unit holds: erased (all 0xFF), a record (magic and CRC hold), or a torn write. */
int boot_record_decode(const uint8_t in[WDR_BOOT_RECORD_SIZE], uint8_t *type, uint32_t *value);

typedef void (*boot_record_visit)(void *ctx, uint8_t type, uint32_t value);

/* Walk the log block at addr (size bytes) from its start: visit every record, skip torn units,
 * stop at the first erased one; *next gets its offset (size when the block is full).
 * @retval WDR_OK  @retval WDR_E_IO  @retval WDR_E_POWER */
int boot_log_walk(const wdr_boot_flash *f, uint32_t addr, uint32_t size, boot_record_visit visit, void *ctx,
                  uint32_t *next);

/* Program one record at offset at of the log block at addr.
 * @retval WDR_OK  @retval WDR_E_TOO_LARGE no unit left  @retval WDR_E_IO  @retval WDR_E_POWER */
int boot_log_put(const wdr_boot_flash *f, uint32_t addr, uint32_t size, uint32_t at, uint8_t type, uint32_t value);

/* A valid slot number. */
static inline bool boot_slot_ok(int slot) { return slot == 0 || slot == 1; }

#endif
