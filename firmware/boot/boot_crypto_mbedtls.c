/* SHA-256 and ECDSA P-256 verification through Mbed TLS 2.28 (the _ret API): Debian's
 * libmbedcrypto on the host, the same release's source for the Cortex-M7 (mbedtls_m7.cmake).
 * The only file of the boot chain that includes Mbed TLS. */
#include "wdr_boot_crypto.h"
#include "wdr_err.h"
#include <mbedtls/bignum.h>
#include <mbedtls/ecdsa.h>
#include <mbedtls/ecp.h>
#include <mbedtls/sha256.h>
#include <stdbool.h>

#if defined(MBEDTLS_MEMORY_BUFFER_ALLOC_C)
/* Bare metal (mbedtls_config_m7.h): Mbed TLS allocates from this static arena, never a heap.
 * One verification at a time. Sized from the mps2-an500 (window 4, no fixed-point table): a
 * verification fails with 4096 bytes and passes with 5120; 8192 leaves the margin. */
#include <mbedtls/memory_buffer_alloc.h>
#ifndef WDR_CRYPTO_ARENA_BYTES
#define WDR_CRYPTO_ARENA_BYTES 8192u
#endif
static unsigned char crypto_arena[WDR_CRYPTO_ARENA_BYTES];

static void crypto_arena_init(void)
{
    static bool ready;
    if (!ready)
        mbedtls_memory_buffer_alloc_init(crypto_arena, sizeof crypto_arena);
    ready = true;
}
#else
static void crypto_arena_init(void) {} /* the host: Mbed TLS's own calloc */
#endif

_Static_assert(sizeof(mbedtls_sha256_context) <= sizeof(((wdr_sha256 *)0)->opaque),
               "wdr_sha256 too small for Mbed TLS's context");
_Static_assert(_Alignof(mbedtls_sha256_context) <= _Alignof(wdr_sha256), "wdr_sha256 under-aligned");

static mbedtls_sha256_context *ctx_of(wdr_sha256 *h) { return (mbedtls_sha256_context *)(void *)h; }

/* With a valid context these calls cannot fail (no hardware accelerator is configured). */
void wdr_sha256_begin(wdr_sha256 *h)
{
    mbedtls_sha256_init(ctx_of(h));
    (void)mbedtls_sha256_starts_ret(ctx_of(h), 0);
}

void wdr_sha256_add(wdr_sha256 *h, const void *data, size_t len)
{
    (void)mbedtls_sha256_update_ret(ctx_of(h), data, len);
}

void wdr_sha256_end(wdr_sha256 *h, uint8_t out[WDR_SHA256_SIZE])
{
    (void)mbedtls_sha256_finish_ret(ctx_of(h), out);
    mbedtls_sha256_free(ctx_of(h));
}

void wdr_sha256_of(const void *data, size_t len, uint8_t out[WDR_SHA256_SIZE])
{
    wdr_sha256 h;
    wdr_sha256_begin(&h);
    wdr_sha256_add(&h, data, len);
    wdr_sha256_end(&h, out);
}

static int error_of(int mbedtls_rc)
{
    if (mbedtls_rc == 0)
        return WDR_OK;
    if (mbedtls_rc == MBEDTLS_ERR_MPI_ALLOC_FAILED || mbedtls_rc == MBEDTLS_ERR_ECP_ALLOC_FAILED)
        return WDR_E_NOMEM;
    return WDR_E_SIGNATURE;
}

/* The key's point on P-256, checked to lie on the curve (a key that is no point is refused
 * before any arithmetic with it). */
static int load_key(mbedtls_ecp_group *grp, mbedtls_ecp_point *q, const uint8_t pubkey[WDR_P256_PUBKEY_SIZE])
{
    int rc = mbedtls_ecp_group_load(grp, MBEDTLS_ECP_DP_SECP256R1);
    if (rc != 0)
        return error_of(rc) == WDR_E_NOMEM ? WDR_E_NOMEM : WDR_E_INVAL;
    rc = mbedtls_ecp_point_read_binary(grp, q, pubkey, WDR_P256_PUBKEY_SIZE);
    if (rc == 0)
        rc = mbedtls_ecp_check_pubkey(grp, q);
    if (rc == MBEDTLS_ERR_MPI_ALLOC_FAILED || rc == MBEDTLS_ERR_ECP_ALLOC_FAILED)
        return WDR_E_NOMEM;
    return rc == 0 ? WDR_OK : WDR_E_INVAL;
}

int wdr_p256_verify(const uint8_t pubkey[WDR_P256_PUBKEY_SIZE], const uint8_t digest[WDR_SHA256_SIZE],
                    const uint8_t sig[WDR_P256_SIG_SIZE])
{
    mbedtls_ecp_group grp;
    mbedtls_ecp_point q;
    mbedtls_mpi r, s;
    crypto_arena_init();
    mbedtls_ecp_group_init(&grp);
    mbedtls_ecp_point_init(&q);
    mbedtls_mpi_init(&r);
    mbedtls_mpi_init(&s);
    int rc = load_key(&grp, &q, pubkey);
    if (rc == WDR_OK) {
        int m = mbedtls_mpi_read_binary(&r, sig, WDR_P256_SIG_SIZE / 2);
        if (m == 0)
            m = mbedtls_mpi_read_binary(&s, sig + WDR_P256_SIG_SIZE / 2, WDR_P256_SIG_SIZE / 2);
        /* r and s out of [1, n-1] fail inside mbedtls_ecdsa_verify */
        if (m == 0)
            m = mbedtls_ecdsa_verify(&grp, digest, WDR_SHA256_SIZE, &q, &r, &s);
        rc = error_of(m);
    }
    mbedtls_mpi_free(&s);
    mbedtls_mpi_free(&r);
    mbedtls_ecp_point_free(&q);
    mbedtls_ecp_group_free(&grp);
    return rc;
}
