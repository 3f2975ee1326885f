/* Boot chain test helpers (boot_test_util.h): OpenSSL signs, the NOR emulator stores. */
#include "boot_test_util.h"
#include "crc32.h"
#include "wdr_err.h"
#include <openssl/core_names.h>
#include <openssl/ec.h>
#include <openssl/evp.h>
#include <openssl/pem.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define DEV_KEY WDR_SOURCE_DIR "/firmware/boot/keys/dev-signing-key.NOT-FOR-PRODUCTION.pem"

static void die(const char *what)
{
    fprintf(stderr, "boot_test_util: %s\n", what);
    abort();
}

static int raw_read(void *ctx, uint32_t addr, void *buf, uint32_t len)
{
    nor_emul *n = ctx;
    if ((uint64_t)addr + len > n->size)
        return WDR_E_INVAL;
    memcpy(buf, n->bytes + addr, len);
    return WDR_OK;
}
static int emul_read(void *ctx, uint32_t addr, void *buf, uint32_t len) { return nor_emul_read(ctx, addr, buf, len); }
static int emul_erase(void *ctx, uint32_t block) { return nor_emul_erase(ctx, block); }
static int emul_prog(void *ctx, uint32_t addr, const void *buf, uint32_t len) { return nor_emul_prog(ctx, addr, buf, len); }
static int no_write(void *ctx, uint32_t a, const void *b, uint32_t l) { (void)ctx; (void)a; (void)b; (void)l; return WDR_E_IO; }
static int no_erase(void *ctx, uint32_t block) { (void)ctx; (void)block; return WDR_E_IO; }

void bt_flash_init(bt_flash *b, uint32_t block_size, uint32_t block_count)
{
    hal_flash_geometry g = {.block_size = block_size, .block_count = block_count, .prog_size = 16};
    if ((uint64_t)block_size * block_count > BT_MAX_FLASH || nor_emul_init(&b->nor, &g, b->bytes, b->programmed))
        die("flash geometry");
    b->f = (wdr_boot_flash){.geo = g, .ctx = &b->nor, .read = emul_read, .erase = emul_erase, .prog = emul_prog};
    if (wdr_boot_layout_init(&b->l, &g) != WDR_OK)
        die("layout refused");
}

wdr_boot_flash bt_flash_raw(bt_flash *b)
{
    wdr_boot_flash f = b->f;
    f.read = raw_read;
    f.erase = no_erase;
    f.prog = no_write;
    return f;
}

static void public_point(bt_key *k)
{
    size_t len = 0;
    if (!EVP_PKEY_get_octet_string_param(k->pkey, OSSL_PKEY_PARAM_PUB_KEY, k->pub, sizeof k->pub, &len) ||
        len != WDR_P256_PUBKEY_SIZE || k->pub[0] != 4)
        die("public point");
}

void bt_key_dev(bt_key *k)
{
    FILE *f = fopen(DEV_KEY, "r");
    if (!f)
        die("cannot open " DEV_KEY);
    k->pkey = PEM_read_PrivateKey(f, NULL, NULL, NULL);
    fclose(f);
    if (!k->pkey)
        die("cannot read " DEV_KEY);
    public_point(k);
}

void bt_key_generate(bt_key *k)
{
    k->pkey = EVP_EC_gen("P-256");
    if (!k->pkey)
        die("EVP_EC_gen");
    public_point(k);
}

bt_image_spec bt_spec(uint8_t major, uint32_t counter, uint32_t app_size)
{
    return (bt_image_spec){.version = {major, 0, 0, 1}, .counter = counter, .load_addr = BT_LOAD_LO,
                           .app_size = app_size, .flags = WDR_IMAGE_F_RAM_LOAD, .seed = major};
}

/* Raw r || s (32 bytes each) of the DER signature OpenSSL makes. */
static void sign_digest(const bt_key *k, const uint8_t digest[32], uint8_t sig[64])
{
    EVP_PKEY_CTX *ctx = EVP_PKEY_CTX_new(k->pkey, NULL);
    uint8_t der[80];
    size_t der_len = sizeof der;
    if (!ctx || EVP_PKEY_sign_init(ctx) <= 0 || EVP_PKEY_sign(ctx, der, &der_len, digest, 32) <= 0)
        die("EVP_PKEY_sign");
    EVP_PKEY_CTX_free(ctx);
    const uint8_t *p = der;
    ECDSA_SIG *s = d2i_ECDSA_SIG(NULL, &p, (long)der_len);
    if (!s || BN_bn2binpad(ECDSA_SIG_get0_r(s), sig, 32) != 32 || BN_bn2binpad(ECDSA_SIG_get0_s(s), sig + 32, 32) != 32)
        die("ECDSA_SIG");
    ECDSA_SIG_free(s);
}

size_t bt_image_build(uint8_t *out, size_t cap, const bt_image_spec *s, const bt_key *signer, const bt_key *hash_key)
{
    size_t total = WDR_IMAGE_HEADER_SIZE + s->app_size + WDR_IMAGE_TRAILER_SIZE;
    if (total > cap)
        die("image does not fit");
    wdr_image_header h = {.image_size = s->app_size, .load_addr = s->load_addr, .version = s->version,
                          .security_counter = s->counter, .flags = s->flags};
    snprintf(h.board, sizeof h.board, "%s", s->board ? s->board : BT_BOARD);
    wdr_image_header_pack(&h, out);
    for (uint32_t i = 0; i < s->app_size; i++)
        out[WDR_IMAGE_HEADER_SIZE + i] = (uint8_t)(i * 7u + s->seed * 31u + (i >> 8));
    wdr_image_trailer t = {0};
    unsigned int dlen = 0;
    if (!EVP_Digest(out, WDR_IMAGE_HEADER_SIZE + s->app_size, t.sha256, &dlen, EVP_sha256(), NULL) ||
        !EVP_Digest((hash_key ? hash_key : signer)->pub, WDR_P256_PUBKEY_SIZE, t.key_hash, &dlen, EVP_sha256(), NULL))
        die("EVP_Digest");
    sign_digest(signer, t.sha256, t.signature);
    wdr_image_trailer_pack(&t, out + WDR_IMAGE_HEADER_SIZE + s->app_size);
    return total;
}

void bt_flash_image(bt_flash *b, int slot, const uint8_t *img, size_t len)
{
    uint32_t bs = b->l.block_size, at = b->l.slot_addr[slot];
    uint8_t unit[16];
    for (uint32_t blk = at / bs; blk < (at + b->l.image_capacity) / bs; blk++)
        if (nor_emul_erase(&b->nor, blk) != WDR_OK)
            die("erase");
    for (size_t off = 0; off < len; off += 16) {
        memset(unit, 0xFF, sizeof unit);
        memcpy(unit, img + off, len - off < 16 ? len - off : 16);
        if (nor_emul_prog(&b->nor, at + (uint32_t)off, unit, 16) != WDR_OK)
            die("program");
    }
}

int bt_upload(bt_flash *b, int slot, const uint8_t *img, size_t len, uint32_t chunk, const wdr_boot_policy *pol)
{
    wdr_boot_upload u;
    int rc = wdr_boot_upload_begin(&b->f, &b->l, &u, slot, (uint32_t)len, wdr_crc32(0, img, len));
    for (size_t off = 0; rc == WDR_OK && off < len; off += chunk)
        rc = wdr_boot_upload_chunk(&b->f, &b->l, &u, (uint32_t)off, img + off,
                                   (uint32_t)(len - off < chunk ? len - off : chunk));
    return rc == WDR_OK ? wdr_boot_upload_finish(&b->f, &b->l, &u, pol, NULL) : rc;
}

wdr_boot_policy bt_policy(const bt_key *trusted)
{
    return (wdr_boot_policy){.board = BT_BOARD, .pubkey = trusted->pub, .load_lo = BT_LOAD_LO,
                             .load_hi = BT_LOAD_HI, .check_signature = true};
}
