/* Checking an image file (see fw_sign.h): every header and trailer field with its own message,
 * then the SHA-256, then the key and the signature. The firmware's codec (image.c) has the last
 * word on structure: a header it refuses is refused here too, whatever the field checks said. */
#include "fw_sign.h"
#include "wdr_bytes.h"
#include "wdr_err.h"
#include <openssl/bn.h>
#include <openssl/ec.h>
#include <openssl/err.h>
#include <openssl/evp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define OFF_BOARD 32u
#define OFF_RESERVED 48u

static int refuse(int code, char *err, size_t cap, const char *name, const char *fmt, unsigned long a, unsigned long b)
{
    char what[256];
    snprintf(what, sizeof what, fmt, a, b);
    snprintf(err, cap, "%s: %s", name, what);
    return code;
}

/* The board field, printable or with its first bad byte named. */
static int check_board(const char *name, const uint8_t *p, char *err, size_t cap)
{
    uint32_t n = 0;
    while (n < WDR_IMAGE_BOARD_MAX && p[n] >= 0x21u && p[n] <= 0x7eu)
        n++;
    if (n == 0 || n == WDR_IMAGE_BOARD_MAX || p[n] != 0)
        return refuse(
            WDR_E_INVAL, err, cap, name,
            "header field board: byte %lu is 0x%02lx, not a printable character or the NUL after 1..15 of them", n,
            n < WDR_IMAGE_BOARD_MAX ? p[n] : 0);
    for (uint32_t i = n; i < WDR_IMAGE_BOARD_MAX; i++)
        if (p[i])
            return refuse(WDR_E_INVAL, err, cap, name,
                          "header field board: byte %lu after the name's NUL is 0x%02lx, not 0", i, p[i]);
    return WDR_OK;
}

static int check_sizes(const char *name, const uint8_t *p, char *err, size_t cap)
{
    uint32_t size = wdr_get_u32(p + 8), load = wdr_get_u32(p + 12);
    if (size < WDR_IMAGE_ALIGN)
        return refuse(WDR_E_INVAL, err, cap, name, "header field image_size: %lu is below %lu", size, WDR_IMAGE_ALIGN);
    if (size % WDR_IMAGE_ALIGN)
        return refuse(WDR_E_INVAL, err, cap, name, "header field image_size: %lu is not a multiple of %lu", size,
                      WDR_IMAGE_ALIGN);
    if (size > WDR_IMAGE_MAX_SIZE)
        return refuse(WDR_E_TOO_LARGE, err, cap, name, "header field image_size: %lu is over the %lu-byte limit", size,
                      WDR_IMAGE_MAX_SIZE);
    if (load % 4u)
        return refuse(WDR_E_INVAL, err, cap, name, "header field load_addr: 0x%08lx is not a multiple of %lu", load, 4);
    return WDR_OK;
}

/* Each header field the codec bounds, named; then the codec itself. */
static int check_header(const char *name, const uint8_t *p, wdr_image_header *h, char *err, size_t cap)
{
    uint32_t magic = wdr_get_u32(p), flags = wdr_get_u32(p + 28);
    if (magic != WDR_IMAGE_MAGIC)
        return refuse(WDR_E_CORRUPT, err, cap, name,
                      "header field magic: 0x%08lx, not 0x%08lx (WIMG): not a signed image", magic, WDR_IMAGE_MAGIC);
    if (p[6] != WDR_IMAGE_VERSION_MAJOR)
        return refuse(WDR_E_VERSION, err, cap, name, "header field format_major: %lu, this tool reads format %lu", p[6],
                      WDR_IMAGE_VERSION_MAJOR);
    if (wdr_get_u16(p + 4) != WDR_IMAGE_HEADER_SIZE)
        return refuse(WDR_E_INVAL, err, cap, name, "header field header_size: %lu, not %lu", wdr_get_u16(p + 4),
                      WDR_IMAGE_HEADER_SIZE);
    int rc = check_sizes(name, p, err, cap);
    if (rc != WDR_OK)
        return rc;
    if (flags & ~WDR_IMAGE_F_KNOWN)
        return refuse(WDR_E_INVAL, err, cap, name, "header field flags: 0x%08lx has unknown bits 0x%08lx", flags,
                      flags & ~WDR_IMAGE_F_KNOWN);
    if ((rc = check_board(name, p + OFF_BOARD, err, cap)) != WDR_OK)
        return rc;
    for (uint32_t i = OFF_RESERVED; i < WDR_IMAGE_HEADER_SIZE; i++)
        if (p[i])
            return refuse(WDR_E_INVAL, err, cap, name, "header field reserved: byte %lu is 0x%02lx, not 0", i, p[i]);
    rc = wdr_image_header_parse(p, UINT32_MAX, h);
    if (rc != WDR_OK)
        snprintf(err, cap, "%s: header refused by the image codec: %s", name, wdr_strerror(rc));
    return rc;
}

static int check_trailer(const char *name, const uint8_t *p, wdr_image_trailer *t, char *err, size_t cap)
{
    uint32_t magic = wdr_get_u32(p);
    if (magic != WDR_IMAGE_TRAILER_MAGIC)
        return refuse(WDR_E_CORRUPT, err, cap, name, "trailer field magic: 0x%08lx, not 0x%08lx (WITL)", magic,
                      WDR_IMAGE_TRAILER_MAGIC);
    if (wdr_get_u16(p + 4) != WDR_IMAGE_TRAILER_SIZE)
        return refuse(WDR_E_INVAL, err, cap, name, "trailer field trailer_size: %lu, not %lu", wdr_get_u16(p + 4),
                      WDR_IMAGE_TRAILER_SIZE);
    if (wdr_get_u16(p + 6) != WDR_IMAGE_SIG_ECDSA_P256)
        return refuse(WDR_E_INVAL, err, cap, name, "trailer field sig_type: %lu, not %lu (ECDSA P-256)",
                      wdr_get_u16(p + 6), WDR_IMAGE_SIG_ECDSA_P256);
    int rc = wdr_image_trailer_parse(p, t);
    if (rc != WDR_OK)
        snprintf(err, cap, "%s: trailer refused by the image codec: %s", name, wdr_strerror(rc));
    return rc;
}

/* Header, the length it implies, trailer. */
static int check_structure(const char *name, const uint8_t *img, size_t len, wdr_fw_image_report *out, char *err,
                           size_t cap)
{
    if (len < WDR_IMAGE_HEADER_SIZE)
        return refuse(WDR_E_TRUNCATED, err, cap, name, "%lu bytes, shorter than the %lu-byte image header", len,
                      WDR_IMAGE_HEADER_SIZE);
    int rc = check_header(name, img, &out->hdr, err, cap);
    if (rc != WDR_OK)
        return rc;
    size_t total = wdr_image_total_size(&out->hdr);
    if (len < total)
        return refuse(WDR_E_TRUNCATED, err, cap, name,
                      "%lu bytes, but header field image_size says %lu (64 + image_size + 136): truncated", len, total);
    if (len > total)
        return refuse(
            WDR_E_INVAL, err, cap, name,
            "%lu bytes, but header field image_size says %lu (64 + image_size + 136): bytes after the trailer", len,
            total);
    return check_trailer(name, img + WDR_IMAGE_HEADER_SIZE + out->hdr.image_size, &out->trl, err, cap);
}

/* r || s to the DER libcrypto verifies; NULL on failure (free with OPENSSL_free). */
static uint8_t *raw_to_der(const uint8_t raw[WDR_P256_SIG_SIZE], int *der_len)
{
    ECDSA_SIG *sig = ECDSA_SIG_new();
    BIGNUM *r = BN_bin2bn(raw, 32, NULL), *s = BN_bin2bn(raw + 32, 32, NULL);
    uint8_t *der = NULL;
    if (sig && r && s && ECDSA_SIG_set0(sig, r, s) == 1) {
        r = s = NULL; /* owned by sig now */
        *der_len = i2d_ECDSA_SIG(sig, &der);
    }
    BN_free(r);
    BN_free(s);
    ECDSA_SIG_free(sig);
    return *der_len > 0 ? der : NULL;
}

static int signature_holds(const wdr_fw_key *key, const uint8_t digest[WDR_SHA256_SIZE],
                           const uint8_t raw[WDR_P256_SIG_SIZE])
{
    int der_len = 0;
    uint8_t *der = raw_to_der(raw, &der_len);
    EVP_PKEY_CTX *ctx = der ? EVP_PKEY_CTX_new((EVP_PKEY *)key->pkey, NULL) : NULL;
    int ok = ctx && EVP_PKEY_verify_init(ctx) == 1 && EVP_PKEY_CTX_set_signature_md(ctx, EVP_sha256()) == 1 &&
             EVP_PKEY_verify(ctx, der, (size_t)der_len, digest, WDR_SHA256_SIZE) == 1;
    EVP_PKEY_CTX_free(ctx);
    OPENSSL_free(der);
    ERR_clear_error();
    return ok;
}

static int is_dev_hash(const uint8_t *hash)
{
    wdr_fw_key dev;
    char err[160];
    if (wdr_fw_key_load_dev(&dev, err, sizeof err) != WDR_OK)
        return 0;
    int same = !memcmp(dev.hash, hash, WDR_SHA256_SIZE);
    wdr_fw_key_free(&dev);
    return same;
}

/* Key hash and signature against key; the signature over the digest computed here, so a
 * damaged image never reads as signed. */
static int check_key(const char *name, const wdr_fw_key *key, wdr_fw_image_report *out, char *err, size_t cap)
{
    char have[2 * WDR_SHA256_SIZE + 1], want[2 * WDR_SHA256_SIZE + 1];
    out->key_checked = 1;
    out->key_matches = !memcmp(out->trl.key_hash, key->hash, WDR_SHA256_SIZE);
    out->signature_ok = signature_holds(key, out->sha256, out->trl.signature);
    wdr_fw_hex(out->trl.key_hash, 8, have);
    wdr_fw_hex(key->hash, 8, want);
    if (!out->key_matches) {
        snprintf(err, cap, "%s: trailer field key_hash: %s..., signed by another key than %s (%s...)", name, have,
                 key->name, want);
        return WDR_E_KEY;
    }
    if (!out->signature_ok) {
        snprintf(err, cap, "%s: trailer field signature: does not verify with %s", name, key->name);
        return WDR_E_SIGNATURE;
    }
    return WDR_OK;
}

int wdr_fw_image_check(const char *name, const uint8_t *img, size_t len, const wdr_fw_key *key,
                       wdr_fw_image_report *out, char *err, size_t cap)
{
    memset(out, 0, sizeof *out);
    int rc = check_structure(name, img, len, out, err, cap);
    if (rc != WDR_OK)
        return rc;
    if (EVP_Digest(img, WDR_IMAGE_HEADER_SIZE + out->hdr.image_size, out->sha256, NULL, EVP_sha256(), NULL) != 1) {
        snprintf(err, cap, "%s: libcrypto could not hash the image", name);
        return WDR_E_NOMEM;
    }
    out->hash_ok = !memcmp(out->sha256, out->trl.sha256, WDR_SHA256_SIZE);
    out->dev_key = (out->hdr.flags & WDR_IMAGE_F_DEV_KEY) || is_dev_hash(out->trl.key_hash);
    int key_rc = key ? check_key(name, key, out, err, cap) : WDR_OK;
    if (!out->hash_ok) {
        char have[2 * WDR_SHA256_SIZE + 1], want[2 * WDR_SHA256_SIZE + 1];
        wdr_fw_hex(out->sha256, 8, have);
        wdr_fw_hex(out->trl.sha256, 8, want);
        snprintf(err, cap,
                 "%s: trailer field sha256: %s..., the header and application hash to %s...: the image is "
                 "damaged",
                 name, want, have);
        return WDR_E_HASH;
    }
    return key_rc;
}
