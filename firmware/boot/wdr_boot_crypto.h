/* The two primitives the boot chain needs, behind a C interface so the bootloader, the
 * firmware and the tests share one implementation (boot_crypto_mbedtls.c: Mbed TLS, Debian's
 * libmbedtls-dev on the host, the same release's source built for the Cortex-M7). Never our
 * own curve code. */
#ifndef WDR_BOOT_CRYPTO_H
#define WDR_BOOT_CRYPTO_H
#include "wdr_image.h"
#include <stddef.h>
#include <stdint.h>

/* Streaming SHA-256; the storage is opaque (large enough for Mbed TLS's context, checked at
 * compile time in the .c). */
typedef struct wdr_sha256 {
    uint64_t opaque[32];
} wdr_sha256;

void wdr_sha256_begin(wdr_sha256 *h);
void wdr_sha256_add(wdr_sha256 *h, const void *data, size_t len);
void wdr_sha256_end(wdr_sha256 *h, uint8_t out[WDR_SHA256_SIZE]);

/* One-shot SHA-256. */
void wdr_sha256_of(const void *data, size_t len, uint8_t out[WDR_SHA256_SIZE]);

/* Verify an ECDSA P-256 signature (raw r || s, big-endian) of a SHA-256 digest with an
 * uncompressed public key. @retval WDR_OK  @retval WDR_E_SIGNATURE does not verify
 * @retval WDR_E_INVAL the key is not a point of the curve  @retval WDR_E_NOMEM the crypto
 * arena ran out (bare-metal builds) */
int wdr_p256_verify(const uint8_t pubkey[WDR_P256_PUBKEY_SIZE], const uint8_t digest[WDR_SHA256_SIZE],
                    const uint8_t sig[WDR_P256_SIG_SIZE]);

#endif
