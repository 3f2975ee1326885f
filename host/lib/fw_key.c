/* P-256 signing keys from PEM files (see fw_sign.h): load, check the curve, take the public
 * point, and tell the tree's development key from any other. */
#include "fw_dev_key.h" /* generated: WDR_FW_DEV_KEY_PEM, the development key's public half */
#include "fw_sign.h"
#include "wdr_err.h"
#include <openssl/bio.h>
#include <openssl/bn.h>
#include <openssl/core_names.h>
#include <openssl/err.h>
#include <openssl/evp.h>
#include <openssl/pem.h>
#include <stdio.h>
#include <string.h>

void wdr_fw_hex(const uint8_t *p, size_t n, char *out)
{
    static const char digits[] = "0123456789abcdef";
    for (size_t i = 0; i < n; i++) {
        out[2 * i] = digits[p[i] >> 4];
        out[2 * i + 1] = digits[p[i] & 15];
    }
    out[2 * n] = 0;
}

/* Never prompt for a passphrase: an encrypted key is refused with a message instead. */
static int no_passphrase(char *buf, int size, int rwflag, void *u)
{
    (void)buf, (void)size, (void)rwflag, (void)u;
    return -1;
}

/* A private key, else a public one, from PEM text in bio. */
static EVP_PKEY *read_pem(BIO *bio, int *has_private)
{
    EVP_PKEY *k = PEM_read_bio_PrivateKey(bio, NULL, no_passphrase, NULL);
    *has_private = k != NULL;
    if (!k && BIO_reset(bio) >= 0) /* file BIOs answer 0 on success, memory BIOs 1 */
        k = PEM_read_bio_PUBKEY(bio, NULL, no_passphrase, NULL);
    ERR_clear_error();
    return k;
}

static int is_p256(EVP_PKEY *k)
{
    char group[64] = "";
    if (EVP_PKEY_get_base_id(k) != EVP_PKEY_EC ||
        !EVP_PKEY_get_utf8_string_param(k, OSSL_PKEY_PARAM_GROUP_NAME, group, sizeof group, NULL))
        return 0;
    return !strcmp(group, "prime256v1") || !strcmp(group, "P-256");
}

/* The uncompressed point from the coordinates, whatever form the file stored it in. */
static int public_point(EVP_PKEY *k, uint8_t out[WDR_P256_PUBKEY_SIZE])
{
    BIGNUM *x = NULL, *y = NULL;
    int ok = EVP_PKEY_get_bn_param(k, OSSL_PKEY_PARAM_EC_PUB_X, &x) &&
             EVP_PKEY_get_bn_param(k, OSSL_PKEY_PARAM_EC_PUB_Y, &y) && BN_bn2binpad(x, out + 1, 32) == 32 &&
             BN_bn2binpad(y, out + 33, 32) == 32;
    out[0] = 0x04;
    BN_free(x);
    BN_free(y);
    return ok;
}

static int key_hash(const uint8_t *point, uint8_t out[WDR_SHA256_SIZE])
{
    return EVP_Digest(point, WDR_P256_PUBKEY_SIZE, out, NULL, EVP_sha256(), NULL) == 1;
}

/* Fill key from an EVP_PKEY (taken over). */
static int take_key(EVP_PKEY *k, int has_private, const char *path, wdr_fw_key *key, char *err, size_t cap)
{
    if (!is_p256(k)) {
        EVP_PKEY_free(k);
        snprintf(err, cap,
                 "%s: not an ECDSA P-256 key (make one with: openssl genpkey -algorithm EC -pkeyopt "
                 "ec_paramgen_curve:P-256 -out KEY.pem)",
                 path);
        return WDR_E_INVAL;
    }
    key->pkey = k;
    key->has_private = has_private;
    snprintf(key->name, sizeof key->name, "%s", path);
    if (!public_point(k, key->point) || !key_hash(key->point, key->hash)) {
        wdr_fw_key_free(key);
        snprintf(err, cap, "%s: cannot read the key's public point", path);
        return WDR_E_INVAL;
    }
    return WDR_OK;
}

static int load_bio(BIO *bio, const char *path, wdr_fw_key *key, char *err, size_t cap)
{
    int has_private = 0;
    EVP_PKEY *k = read_pem(bio, &has_private);
    if (!k) {
        snprintf(err, cap, "%s: not a PEM key (or an encrypted one: decrypt it with openssl pkey first)", path);
        return WDR_E_INVAL;
    }
    return take_key(k, has_private, path, key, err, cap);
}

int wdr_fw_key_load_dev(wdr_fw_key *key, char *err, size_t cap)
{
    memset(key, 0, sizeof *key);
    BIO *bio = BIO_new_mem_buf(WDR_FW_DEV_KEY_PEM, -1);
    if (!bio) {
        snprintf(err, cap, "out of memory");
        return WDR_E_NOMEM;
    }
    int rc = load_bio(bio, "the built-in development key", key, err, cap);
    BIO_free(bio);
    key->is_dev = rc == WDR_OK;
    return rc;
}

/* Whether point is the development key's. */
static int is_dev_point(const uint8_t *point)
{
    wdr_fw_key dev;
    char err[160];
    if (wdr_fw_key_load_dev(&dev, err, sizeof err) != WDR_OK)
        return 0;
    int same = !memcmp(dev.point, point, WDR_P256_PUBKEY_SIZE);
    wdr_fw_key_free(&dev);
    return same;
}

int wdr_fw_key_load(const char *path, int need_private, wdr_fw_key *key, char *err, size_t cap)
{
    memset(key, 0, sizeof *key);
    BIO *bio = BIO_new_file(path, "r");
    if (!bio) {
        ERR_clear_error();
        snprintf(err, cap, "%s: cannot read the key file", path);
        return WDR_E_IO;
    }
    int rc = load_bio(bio, path, key, err, cap);
    BIO_free(bio);
    if (rc == WDR_OK && need_private && !key->has_private) {
        wdr_fw_key_free(key);
        snprintf(err, cap, "%s: a public key cannot sign: give the private key (the PEM from openssl genpkey)", path);
        return WDR_E_INVAL;
    }
    if (rc == WDR_OK)
        key->is_dev = is_dev_point(key->point);
    return rc;
}

void wdr_fw_key_free(wdr_fw_key *key)
{
    EVP_PKEY_free(key->pkey);
    memset(key, 0, sizeof *key);
}
