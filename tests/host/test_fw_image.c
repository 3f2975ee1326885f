/* Signed images on the host (host/lib/fw_sign.h): sign and check round trip with the
 * development key and a fresh one; a flipped byte anywhere the hash covers fails the hash; a
 * flipped signature byte fails the signature; another key fails the key hash; each malformed
 * field is refused with its name; keys of other curves and types are refused naming the file.
 * The signature and key hash are also checked here by libcrypto directly, not through
 * fw_verify.c, so a mistake shared by signer and checker (r and s swapped, a compressed point
 * hashed) still fails. */
#include "fw_sign.h"
#include "wdr_bytes.h"
#include "wdr_err.h"
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <cmocka.h>
#include <openssl/bn.h>
#include <openssl/ec.h>
#include <openssl/evp.h>
#include <openssl/pem.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#ifndef WDR_DEV_KEY_DIR
#error "WDR_DEV_KEY_DIR must name firmware/boot/keys"
#endif
#define DEV_KEY WDR_DEV_KEY_DIR "/dev-signing-key.NOT-FOR-PRODUCTION.pem"
#define DEV_PUB WDR_DEV_KEY_DIR "/dev-signing-key.NOT-FOR-PRODUCTION.pub.pem"
#define APP_LEN 1000u /* padded to 1008 */

static char dir[64], other_key[128], p384_key[128], ed_key[128], junk_key[128], enc_key[128], comp_pub[128];
static uint8_t app[APP_LEN];

static void write_pkey(const char *path, EVP_PKEY *k)
{
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    assert_int_equal(PEM_write_PrivateKey(f, k, NULL, NULL, 0, NULL, NULL), 1);
    fclose(f);
    EVP_PKEY_free(k);
}

static int setup(void **state)
{
    (void)state;
    snprintf(dir, sizeof dir, "/tmp/wdr_fw_image_XXXXXX");
    assert_non_null(mkdtemp(dir));
    snprintf(other_key, sizeof other_key, "%s/other.pem", dir);
    snprintf(p384_key, sizeof p384_key, "%s/p384.pem", dir);
    snprintf(ed_key, sizeof ed_key, "%s/ed25519.pem", dir);
    snprintf(junk_key, sizeof junk_key, "%s/junk.pem", dir);
    write_pkey(other_key, EVP_EC_gen("P-256"));
    write_pkey(p384_key, EVP_EC_gen("P-384"));
    write_pkey(ed_key, EVP_PKEY_Q_keygen(NULL, NULL, "ED25519"));
    FILE *f = fopen(junk_key, "w");
    assert_non_null(f);
    fputs("-----BEGIN PRIVATE KEY-----\nnot base64 at all\n-----END PRIVATE KEY-----\n", f);
    fclose(f);
    /* the other key encrypted with a passphrase; the development key's public half, compressed */
    snprintf(enc_key, sizeof enc_key, "%s/encrypted.pem", dir);
    snprintf(comp_pub, sizeof comp_pub, "%s/compressed.pub.pem", dir);
    f = fopen(other_key, "r");
    EVP_PKEY *k = PEM_read_PrivateKey(f, NULL, NULL, NULL);
    fclose(f);
    f = fopen(enc_key, "w");
    assert_int_equal(PEM_write_PrivateKey(f, k, EVP_aes_256_cbc(), (unsigned char *)"secret", 6, NULL, NULL), 1);
    fclose(f);
    EVP_PKEY_free(k);
    f = fopen(DEV_PUB, "r");
    k = PEM_read_PUBKEY(f, NULL, NULL, NULL);
    fclose(f);
    assert_int_equal(EVP_PKEY_set_utf8_string_param(k, "point-format", "compressed"), 1);
    assert_int_equal(i2d_PUBKEY(k, NULL), 59); /* 91 uncompressed */
    f = fopen(comp_pub, "w");
    assert_int_equal(PEM_write_PUBKEY(f, k), 1);
    fclose(f);
    EVP_PKEY_free(k);
    for (unsigned i = 0; i < APP_LEN; i++)
        app[i] = (uint8_t)(i * 37u + 11u);
    return 0;
}

static int teardown(void **state)
{
    (void)state;
    const char *names[] = {other_key, p384_key, ed_key, junk_key, enc_key, comp_pub};
    for (size_t i = 0; i < 6; i++)
        unlink(names[i]);
    rmdir(dir);
    return 0;
}

static const wdr_fw_sign_params params = {
    .version = {2, 3, 4, 56}, .security_counter = 7, .load_addr = 0x00400000u, .board = "sim-vga", .ram_load = 1};

static wdr_fw_key load(const char *path, int need_private)
{
    wdr_fw_key k;
    char err[512];
    int rc = wdr_fw_key_load(path, need_private, &k, err, sizeof err);
    if (rc != WDR_OK)
        fail_msg("%s", err);
    return k;
}

static uint8_t *sign_with(const char *key_path, const wdr_fw_sign_params *p, size_t *len)
{
    wdr_fw_key k = load(key_path, 1);
    uint8_t *img = NULL;
    char err[512];
    int rc = wdr_fw_sign("app.bin", app, APP_LEN, p, &k, &img, len, err, sizeof err);
    wdr_fw_key_free(&k);
    if (rc != WDR_OK)
        fail_msg("%s", err);
    return img;
}

/* Check img with the key at key_path (NULL: none); returns the code, *r and err filled. */
static int check_with(const char *key_path, const uint8_t *img, size_t len, wdr_fw_image_report *r, char *err)
{
    wdr_fw_key k;
    if (key_path)
        k = load(key_path, 0);
    int rc = wdr_fw_image_check("APP.img", img, len, key_path ? &k : NULL, r, err, 512);
    if (key_path)
        wdr_fw_key_free(&k);
    return rc;
}

/* ---- Independent of fw_verify.c: libcrypto on the raw bytes -------------------------------------- */

/* The key hash is SHA-256 of the 65-byte point inside the PEM's SubjectPublicKeyInfo DER. */
static void assert_key_hash_of(const char *pub_path, const uint8_t *hash)
{
    FILE *f = fopen(pub_path, "r");
    assert_non_null(f);
    EVP_PKEY *k = PEM_read_PUBKEY(f, NULL, NULL, NULL);
    fclose(f);
    assert_non_null(k);
    uint8_t *der = NULL, digest[32];
    int n = i2d_PUBKEY(k, &der);
    assert_true(n > 65);
    assert_int_equal(der[n - 65], 0x04);
    assert_int_equal(EVP_Digest(der + n - 65, 65, digest, NULL, EVP_sha256(), NULL), 1);
    assert_memory_equal(digest, hash, 32);
    OPENSSL_free(der);
    EVP_PKEY_free(k);
}

/* r || s of the trailer, made DER by hand here, verifies over SHA-256 of header and application. */
static void assert_signature_independently(const char *pub_path, const uint8_t *img, size_t len)
{
    uint32_t size = wdr_get_u32(img + 8);
    const uint8_t *trl = img + len - WDR_IMAGE_TRAILER_SIZE, *raw = trl + 72;
    uint8_t digest[32];
    assert_int_equal(EVP_Digest(img, 64 + size, digest, NULL, EVP_sha256(), NULL), 1);
    assert_memory_equal(digest, trl + 8, 32);
    ECDSA_SIG *sig = ECDSA_SIG_new();
    assert_int_equal(ECDSA_SIG_set0(sig, BN_bin2bn(raw, 32, NULL), BN_bin2bn(raw + 32, 32, NULL)), 1);
    uint8_t *der = NULL;
    int der_len = i2d_ECDSA_SIG(sig, &der);
    FILE *f = fopen(pub_path, "r");
    assert_non_null(f);
    EVP_PKEY *k = PEM_read_PUBKEY(f, NULL, NULL, NULL);
    fclose(f);
    EVP_PKEY_CTX *ctx = EVP_PKEY_CTX_new(k, NULL);
    assert_int_equal(EVP_PKEY_verify_init(ctx), 1);
    assert_int_equal(EVP_PKEY_CTX_set_signature_md(ctx, EVP_sha256()), 1);
    assert_int_equal(EVP_PKEY_verify(ctx, der, (size_t)der_len, digest, 32), 1);
    EVP_PKEY_CTX_free(ctx);
    EVP_PKEY_free(k);
    OPENSSL_free(der);
    ECDSA_SIG_free(sig);
}

/* ---- Cases ------------------------------------------------------------------------------------------ */

static void sign_and_check_round_trip(void **state)
{
    (void)state;
    size_t len = 0;
    uint8_t *img = sign_with(DEV_KEY, &params, &len);
    assert_int_equal(len, 64 + 1008 + 136);
    for (unsigned i = APP_LEN; i < 1008; i++)
        assert_int_equal(img[64 + i], 0); /* zero padding */
    assert_memory_equal(img + 64, app, APP_LEN);
    wdr_fw_image_report r;
    char err[512] = "";
    int rc = check_with(DEV_PUB, img, len, &r, err);
    if (rc != WDR_OK)
        fail_msg("%s", err);
    assert_true(r.hash_ok && r.key_checked && r.key_matches && r.signature_ok && r.dev_key);
    assert_int_equal(r.hdr.image_size, 1008);
    assert_int_equal(r.hdr.load_addr, 0x00400000u);
    assert_int_equal(r.hdr.security_counter, 7);
    assert_int_equal(r.hdr.version.major, 2);
    assert_int_equal(r.hdr.version.minor, 3);
    assert_int_equal(r.hdr.version.patch, 4);
    assert_int_equal(r.hdr.version.build, 56);
    assert_string_equal(r.hdr.board, "sim-vga");
    assert_int_equal(r.hdr.flags, WDR_IMAGE_F_RAM_LOAD | WDR_IMAGE_F_DEV_KEY);
    /* the firmware's own codec reads it too */
    wdr_image_header h;
    assert_int_equal(wdr_image_header_parse(img, (uint32_t)len, &h), WDR_OK);
    assert_key_hash_of(DEV_PUB, r.trl.key_hash);
    assert_signature_independently(DEV_PUB, img, len);
    free(img);
}

static void other_key_round_trip_is_not_dev(void **state)
{
    (void)state;
    size_t len = 0;
    wdr_fw_sign_params p = params;
    p.ram_load = 0;
    uint8_t *img = sign_with(other_key, &p, &len);
    wdr_fw_image_report r;
    char err[512] = "";
    assert_int_equal(check_with(other_key, img, len, &r, err), WDR_OK); /* a private key checks too */
    assert_false(r.dev_key);
    assert_int_equal(r.hdr.flags, 0);
    wdr_fw_key k = load(other_key, 1);
    assert_false(k.is_dev);
    wdr_fw_key_free(&k);
    free(img);
}

static void flipped_byte_fails_the_hash(void **state)
{
    (void)state;
    size_t len = 0;
    uint8_t *img = sign_with(DEV_KEY, &params, &len);
    /* a version byte, the counter, the first and last application bytes, a padding byte */
    const size_t at[] = {16, 24, 64, 64 + APP_LEN - 1, 64 + 1007};
    for (size_t i = 0; i < sizeof at / sizeof at[0]; i++) {
        img[at[i]] ^= 0x01;
        wdr_fw_image_report r;
        char err[512] = "";
        assert_int_equal(check_with(DEV_PUB, img, len, &r, err), WDR_E_HASH);
        assert_false(r.hash_ok);
        assert_false(r.signature_ok); /* checked over the bytes as they are */
        assert_non_null(strstr(err, "APP.img: trailer field sha256"));
        assert_int_equal(check_with(NULL, img, len, &r, err), WDR_E_HASH); /* no key needed to see it */
        img[at[i]] ^= 0x01;
    }
    free(img);
}

static void flipped_signature_byte_fails_the_signature(void **state)
{
    (void)state;
    size_t len = 0;
    uint8_t *img = sign_with(DEV_KEY, &params, &len);
    const size_t sig = len - WDR_IMAGE_TRAILER_SIZE + 72;
    const size_t at[] = {sig, sig + 31, sig + 32, sig + 63};
    for (size_t i = 0; i < sizeof at / sizeof at[0]; i++) {
        img[at[i]] ^= 0x80;
        wdr_fw_image_report r;
        char err[512] = "";
        assert_int_equal(check_with(DEV_PUB, img, len, &r, err), WDR_E_SIGNATURE);
        assert_true(r.hash_ok && r.key_matches);
        assert_false(r.signature_ok);
        assert_non_null(strstr(err, "trailer field signature: does not verify with"));
        img[at[i]] ^= 0x80;
    }
    free(img);
}

static void other_key_fails_the_key_hash(void **state)
{
    (void)state;
    size_t len = 0;
    uint8_t *img = sign_with(DEV_KEY, &params, &len);
    wdr_fw_image_report r;
    char err[512] = "";
    assert_int_equal(check_with(other_key, img, len, &r, err), WDR_E_KEY);
    assert_true(r.hash_ok);
    assert_false(r.key_matches);
    assert_false(r.signature_ok);
    assert_non_null(strstr(err, "signed by another key than"));
    free(img);
    img = sign_with(other_key, &params, &len);
    assert_int_equal(check_with(DEV_PUB, img, len, &r, err), WDR_E_KEY);
    /* the right key hash with a foreign signature: the signature check, not the hash, refuses it */
    wdr_fw_key dev = load(DEV_PUB, 0);
    memcpy(img + len - WDR_IMAGE_TRAILER_SIZE + 40, dev.hash, 32);
    wdr_fw_key_free(&dev);
    assert_int_equal(check_with(DEV_PUB, img, len, &r, err), WDR_E_SIGNATURE);
    free(img);
}

typedef struct bad_case {
    const char *what;
    size_t at;      /* byte to set (SIZE_MAX: none) */
    uint32_t value; /* little-endian, width bytes */
    int width;
    long len_delta; /* bytes added (or removed) at the end */
    int code;
    const char *message;
} bad_case;

static void malformed_fields_are_named(void **state)
{
    (void)state;
    size_t len = 0;
    uint8_t *good = sign_with(DEV_KEY, &params, &len);
    const size_t trl = len - WDR_IMAGE_TRAILER_SIZE;
    const bad_case cases[] = {
        {"magic", 0, 0x12345678u, 4, 0, WDR_E_CORRUPT, "APP.img: header field magic: 0x12345678"},
        {"format major", 6, 2, 1, 0, WDR_E_VERSION, "APP.img: header field format_major: 2"},
        {"header size", 4, 65, 2, 0, WDR_E_INVAL, "APP.img: header field header_size: 65, not 64"},
        {"image size 17", 8, 17, 4, 0, WDR_E_INVAL, "APP.img: header field image_size: 17 is not a multiple of 16"},
        {"image size 0", 8, 0, 4, 0, WDR_E_INVAL, "APP.img: header field image_size: 0 is below 16"},
        {"image size huge", 8, (16u << 20) + 16u, 4, 0, WDR_E_TOO_LARGE, "header field image_size: 16777232 is over"},
        {"load addr", 12, 0x400002u, 4, 0, WDR_E_INVAL,
         "APP.img: header field load_addr: 0x00400002 is not a multiple of 4"},
        {"flags", 28, 0x11u, 4, 0, WDR_E_INVAL, "APP.img: header field flags: 0x00000011 has unknown bits 0x00000010"},
        {"board blank", 32, ' ', 1, 0, WDR_E_INVAL, "APP.img: header field board: byte 0 is 0x20"},
        {"board tail", 47, 'x', 1, 0, WDR_E_INVAL, "APP.img: header field board: byte 15 after the name's NUL is 0x78"},
        {"reserved", 50, 1, 1, 0, WDR_E_INVAL, "APP.img: header field reserved: byte 50 is 0x01"},
        {"truncated", SIZE_MAX, 0, 0, -1, WDR_E_TRUNCATED,
         "APP.img: 1207 bytes, but header field image_size says 1208"},
        {"trailing bytes", SIZE_MAX, 0, 0, 16, WDR_E_INVAL, "bytes after the trailer"},
        {"trailer magic", trl, 0, 4, 0, WDR_E_CORRUPT, "APP.img: trailer field magic: 0x00000000, not 0x4c544957"},
        {"trailer size", trl + 4, 100, 2, 0, WDR_E_INVAL, "APP.img: trailer field trailer_size: 100, not 136"},
        {"sig type", trl + 6, 2, 2, 0, WDR_E_INVAL, "APP.img: trailer field sig_type: 2, not 1"},
        {"short", SIZE_MAX, 0, 0, -(long)len + 10, WDR_E_TRUNCATED, "APP.img: 10 bytes, shorter than the 64-byte"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        const bad_case *c = &cases[i];
        size_t n = (size_t)((long)len + c->len_delta);
        uint8_t *img = calloc(1, len + 64);
        memcpy(img, good, len);
        for (int b = 0; b < c->width; b++)
            img[c->at + (size_t)b] = (uint8_t)(c->value >> (8 * b));
        wdr_fw_image_report r;
        char err[512] = "";
        int rc = check_with(DEV_PUB, img, n, &r, err);
        if (rc != c->code || !strstr(err, c->message))
            fail_msg("%s: got %d '%s', expected %d '%s'", c->what, rc, err, c->code, c->message);
        free(img);
    }
    free(good);
}

static void bad_sign_parameters_are_refused(void **state)
{
    (void)state;
    wdr_fw_key k = load(DEV_KEY, 1);
    const char *boards[] = {"", "with space", "sixteen-chars-xx", "tab\tname"};
    uint8_t *img = NULL;
    size_t len = 0;
    char err[512];
    for (size_t i = 0; i < 4; i++) {
        wdr_fw_sign_params p = params;
        p.board = boards[i];
        assert_int_equal(wdr_fw_sign("app.bin", app, APP_LEN, &p, &k, &img, &len, err, sizeof err), WDR_E_INVAL);
        assert_non_null(strstr(err, "header field board"));
        assert_null(img);
    }
    wdr_fw_sign_params p = params;
    p.load_addr = 0x401;
    assert_int_equal(wdr_fw_sign("app.bin", app, APP_LEN, &p, &k, &img, &len, err, sizeof err), WDR_E_INVAL);
    assert_non_null(strstr(err, "header field load_addr: 0x00000401"));
    assert_int_equal(wdr_fw_sign("app.bin", app, 0, &params, &k, &img, &len, err, sizeof err), WDR_E_INVAL);
    assert_non_null(strstr(err, "app.bin: empty file"));
    const uint8_t elf[8] = {0x7f, 'E', 'L', 'F', 1, 1, 1, 0};
    assert_int_equal(wdr_fw_sign("app.elf", elf, sizeof elf, &params, &k, &img, &len, err, sizeof err), WDR_E_INVAL);
    assert_non_null(strstr(err, "app.elf: an ELF file"));
    uint8_t *signed_once = NULL;
    size_t once_len = 0;
    assert_int_equal(wdr_fw_sign("app.bin", app, APP_LEN, &params, &k, &signed_once, &once_len, err, sizeof err),
                     WDR_OK);
    assert_int_equal(wdr_fw_sign("app.img", signed_once, once_len, &params, &k, &img, &len, err, sizeof err),
                     WDR_E_INVAL);
    assert_non_null(strstr(err, "app.img: already a signed image"));
    free(signed_once);
    wdr_fw_key_free(&k);
    k = load(DEV_PUB, 0);
    assert_int_equal(wdr_fw_sign("app.bin", app, APP_LEN, &params, &k, &img, &len, err, sizeof err), WDR_E_INVAL);
    wdr_fw_key_free(&k);
}

static void keys_other_than_p256_are_refused_by_name(void **state)
{
    (void)state;
    const char *paths[] = {p384_key, ed_key, junk_key, enc_key};
    const char *says[] = {"not an ECDSA P-256 key", "not an ECDSA P-256 key", "not a PEM key", "an encrypted one"};
    for (size_t i = 0; i < 4; i++) {
        wdr_fw_key k;
        char err[512] = "";
        assert_int_equal(wdr_fw_key_load(paths[i], 0, &k, err, sizeof err), WDR_E_INVAL);
        assert_true(!strncmp(err, paths[i], strlen(paths[i])));
        assert_non_null(strstr(err, says[i]));
    }
    wdr_fw_key k;
    char err[512] = "";
    assert_int_equal(wdr_fw_key_load("/nonexistent/key.pem", 0, &k, err, sizeof err), WDR_E_IO);
    assert_non_null(strstr(err, "/nonexistent/key.pem"));
    assert_int_equal(wdr_fw_key_load(DEV_PUB, 1, &k, err, sizeof err), WDR_E_INVAL);
    assert_non_null(strstr(err, "a public key cannot sign"));
    k = load(DEV_PUB, 0);
    assert_true(k.is_dev);
    /* a public key stored compressed is the same key: the hash is of the uncompressed point */
    wdr_fw_key c = load(comp_pub, 0);
    assert_true(c.is_dev);
    assert_memory_equal(c.hash, k.hash, 32);
    assert_int_equal(c.point[0], 0x04);
    wdr_fw_key_free(&c);
    wdr_fw_key_free(&k);
}

static void versions_parse_strictly(void **state)
{
    (void)state;
    wdr_image_version v;
    char text[48];
    assert_int_equal(wdr_fw_version_parse("1.2.3", &v), WDR_OK);
    assert_true(v.major == 1 && v.minor == 2 && v.patch == 3 && v.build == 0);
    assert_int_equal(wdr_fw_version_parse("255.255.65535+4294967295", &v), WDR_OK);
    assert_int_equal(v.build, 4294967295u);
    wdr_fw_version_format(&v, text, sizeof text);
    assert_string_equal(text, "255.255.65535+4294967295");
    const char *bad[] = {
        "",       "1",      "1.2",    "1.2.3.4", "256.0.0", "0.256.0",  "0.0.65536", "1.2.3+", "1.2.3+4294967296",
        "-1.2.3", " 1.2.3", "1.2.3 ", "1.2.x",   "1..3",    "1.2.3-rc1"};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++)
        if (wdr_fw_version_parse(bad[i], &v) != WDR_E_INVAL)
            fail_msg("'%s' parsed", bad[i]);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(sign_and_check_round_trip),       cmocka_unit_test(other_key_round_trip_is_not_dev),
        cmocka_unit_test(flipped_byte_fails_the_hash),     cmocka_unit_test(flipped_signature_byte_fails_the_signature),
        cmocka_unit_test(other_key_fails_the_key_hash),    cmocka_unit_test(malformed_fields_are_named),
        cmocka_unit_test(bad_sign_parameters_are_refused), cmocka_unit_test(keys_other_than_p256_are_refused_by_name),
        cmocka_unit_test(versions_parse_strictly),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
