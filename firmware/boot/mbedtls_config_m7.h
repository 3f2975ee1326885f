/* Mbed TLS 2.28 configuration for the Cortex-M7 images (bootloader and firmware), given to the
 * library's sources and to boot_crypto_mbedtls.c as MBEDTLS_CONFIG_FILE: only what verifying an
 * ECDSA P-256 signature over a SHA-256 digest needs. Bare metal: no heap (allocations come from
 * a static arena, MEMORY_BUFFER_ALLOC_C), no entropy source, no file system, no clock. The host
 * build uses Debian's libmbedtls-dev with its own default configuration instead. */
#ifndef WDR_MBEDTLS_CONFIG_M7_H
#define WDR_MBEDTLS_CONFIG_M7_H

/* System: the Thumb-2 multiply-accumulate assembly in bignum (UMAAL on the M7). */
#define MBEDTLS_HAVE_ASM
#define MBEDTLS_NO_PLATFORM_ENTROPY
#define MBEDTLS_NO_UDBL_DIVISION /* no 64-bit division helper calls in bignum */

/* Memory: mbedtls_calloc/free through the platform layer; without an arena they return NULL
 * (never newlib's heap); boot_crypto_mbedtls.c installs the static arena. */
#define MBEDTLS_PLATFORM_C
#define MBEDTLS_PLATFORM_NO_STD_FUNCTIONS /* else Mbed TLS allocates from newlib's heap */
#define MBEDTLS_PLATFORM_MEMORY
#define MBEDTLS_MEMORY_BUFFER_ALLOC_C

/* Hash. */
#define MBEDTLS_SHA256_C

/* Signature verification: one curve, the NIST fast reduction. Verification handles no secret,
 * so ECP's internal blinding RNG (a DRBG dependency) is left out. */
#define MBEDTLS_BIGNUM_C
#define MBEDTLS_ECP_C
#define MBEDTLS_ECDSA_C
#define MBEDTLS_ASN1_PARSE_C /* ECDSA's prerequisites (DER signatures; ours are raw r || s) */
#define MBEDTLS_ASN1_WRITE_C
#define MBEDTLS_ECP_DP_SECP256R1_ENABLED
#define MBEDTLS_ECP_NIST_OPTIM
#define MBEDTLS_ECP_NO_INTERNAL_RNG
/* The arena's size follows from these two: window 4 keeps 8 points per multiplication; the
 * fixed-point table for G would cache 2^(w-1) more points for the group's lifetime. */
#define MBEDTLS_ECP_WINDOW_SIZE 4
#define MBEDTLS_ECP_FIXED_POINT_OPTIM 0
#define MBEDTLS_MPI_WINDOW_SIZE 2

#include "mbedtls/check_config.h"
#endif
