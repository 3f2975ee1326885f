/* The public key this build trusts (generated/wdr_boot_key.h, from -DWDR_SIGNING_KEY): the one
 * file that includes the generated header, so the key is in the image once. */
#include "wdr_boot.h"
#include "wdr_boot_key.h"

const uint8_t *wdr_boot_key(void) { return wdr_boot_trusted_key; }

bool wdr_boot_key_is_dev(void) { return WDR_BOOT_KEY_IS_DEV != 0; }
