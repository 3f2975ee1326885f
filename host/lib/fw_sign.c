/* Signing an application into a firmware image (see fw_sign.h; layout in firmware/SPEC.md,
 * "Firmware image format"): header, application padded to 16, trailer with the SHA-256 of both,
 * the key's hash and the ECDSA P-256 signature as raw r || s. */
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

/* The board name the header can hold: 1..15 printable ASCII characters, no blanks. */
static int board_name_ok(const char *b)
{
    size_t n = b ? strlen(b) : 0;
    if (n == 0 || n >= WDR_IMAGE_BOARD_MAX)
        return 0;
    for (size_t i = 0; i < n; i++)
        if ((unsigned char)b[i] < 0x21u || (unsigned char)b[i] > 0x7eu)
            return 0;
    return 1;
}

static int check_params(const char *name, const uint8_t *app, size_t len, const wdr_fw_sign_params *p,
                        const wdr_fw_key *key, char *err, size_t cap)
{
    if (!key->has_private) {
        snprintf(err, cap, "%s: a public key cannot sign", key->name);
        return WDR_E_INVAL;
    }
    if (len == 0) {
        snprintf(err, cap, "%s: empty file: no application to sign", name);
        return WDR_E_INVAL;
    }
    if (len >= 4 && !memcmp(app,
                            "\x7f"
                            "ELF",
                            4)) {
        snprintf(err, cap, "%s: an ELF file: sign the application's raw .bin (objcopy -O binary)", name);
        return WDR_E_INVAL;
    }
    if (len >= 4 && wdr_get_u32(app) == WDR_IMAGE_MAGIC) {
        snprintf(err, cap, "%s: already a signed image (header magic WIMG): sign the application's .bin", name);
        return WDR_E_INVAL;
    }
    if (len > WDR_IMAGE_MAX_SIZE) {
        snprintf(err, cap, "%s: %zu bytes; an image holds at most %u application bytes", name, len, WDR_IMAGE_MAX_SIZE);
        return WDR_E_TOO_LARGE;
    }
    if (!board_name_ok(p->board)) {
        snprintf(err, cap, "header field board: '%s' is not 1..%u printable ASCII characters without blanks",
                 p->board ? p->board : "", WDR_IMAGE_BOARD_MAX - 1);
        return WDR_E_INVAL;
    }
    if (p->load_addr % 4u) {
        snprintf(err, cap, "header field load_addr: 0x%08x is not a multiple of 4", p->load_addr);
        return WDR_E_INVAL;
    }
    return WDR_OK;
}

/* DER (what libcrypto signs) to r || s, each 32 bytes big-endian, left-padded. */
static int der_to_raw(const uint8_t *der, size_t der_len, uint8_t out[WDR_P256_SIG_SIZE])
{
    const unsigned char *q = der;
    ECDSA_SIG *sig = d2i_ECDSA_SIG(NULL, &q, (long)der_len);
    if (!sig)
        return 0;
    const BIGNUM *r = NULL, *s = NULL;
    ECDSA_SIG_get0(sig, &r, &s);
    int ok = BN_bn2binpad(r, out, 32) == 32 && BN_bn2binpad(s, out + 32, 32) == 32;
    ECDSA_SIG_free(sig);
    return ok;
}

/* ECDSA P-256 over an already computed SHA-256 digest. */
static int sign_digest(const wdr_fw_key *key, const uint8_t digest[WDR_SHA256_SIZE], uint8_t out[WDR_P256_SIG_SIZE])
{
    EVP_PKEY_CTX *ctx = EVP_PKEY_CTX_new((EVP_PKEY *)key->pkey, NULL);
    uint8_t der[128];
    size_t der_len = sizeof der;
    int ok = ctx && EVP_PKEY_sign_init(ctx) == 1 && EVP_PKEY_CTX_set_signature_md(ctx, EVP_sha256()) == 1 &&
             EVP_PKEY_sign(ctx, der, &der_len, digest, WDR_SHA256_SIZE) == 1 && der_to_raw(der, der_len, out);
    EVP_PKEY_CTX_free(ctx);
    ERR_clear_error();
    return ok;
}

static wdr_image_header header_for(const wdr_fw_sign_params *p, const wdr_fw_key *key, uint32_t image_size)
{
    wdr_image_header h = {.header_size = WDR_IMAGE_HEADER_SIZE,
                          .format_major = WDR_IMAGE_VERSION_MAJOR,
                          .format_minor = WDR_IMAGE_VERSION_MINOR,
                          .image_size = image_size,
                          .load_addr = p->load_addr,
                          .version = p->version,
                          .security_counter = p->security_counter,
                          .flags =
                              (p->ram_load ? WDR_IMAGE_F_RAM_LOAD : 0u) | (key->is_dev ? WDR_IMAGE_F_DEV_KEY : 0u)};
    snprintf(h.board, sizeof h.board, "%s", p->board);
    return h;
}

int wdr_fw_sign(const char *name, const uint8_t *app, size_t len, const wdr_fw_sign_params *p, const wdr_fw_key *key,
                uint8_t **img, size_t *img_len, char *err, size_t cap)
{
    *img = NULL;
    *img_len = 0;
    int rc = check_params(name, app, len, p, key, err, cap);
    if (rc != WDR_OK)
        return rc;
    uint32_t image_size = (uint32_t)((len + WDR_IMAGE_ALIGN - 1) / WDR_IMAGE_ALIGN * WDR_IMAGE_ALIGN);
    wdr_image_header h = header_for(p, key, image_size);
    size_t total = wdr_image_total_size(&h);
    uint8_t *buf = calloc(1, total); /* zeroes: the padding */
    if (!buf) {
        snprintf(err, cap, "out of memory for a %zu-byte image", total);
        return WDR_E_NOMEM;
    }
    wdr_image_header_pack(&h, buf);
    memcpy(buf + WDR_IMAGE_HEADER_SIZE, app, len);
    wdr_image_trailer t = {.trailer_size = WDR_IMAGE_TRAILER_SIZE, .sig_type = WDR_IMAGE_SIG_ECDSA_P256};
    memcpy(t.key_hash, key->hash, WDR_SHA256_SIZE);
    if (EVP_Digest(buf, WDR_IMAGE_HEADER_SIZE + image_size, t.sha256, NULL, EVP_sha256(), NULL) != 1 ||
        !sign_digest(key, t.sha256, t.signature)) {
        free(buf);
        snprintf(err, cap, "%s: libcrypto could not sign with %s", name, key->name);
        return WDR_E_SIGNATURE;
    }
    wdr_image_trailer_pack(&t, buf + WDR_IMAGE_HEADER_SIZE + image_size);
    *img = buf;
    *img_len = total;
    return WDR_OK;
}
