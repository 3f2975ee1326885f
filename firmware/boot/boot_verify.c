/* wdr_image_verify: every check an image must pass before it is marked pending and before it
 * runs, in SPEC.md's order, each with its own refusal. The image is hashed as it is read, in
 * small chunks, so no buffer holds more than BOOT_READ_CHUNK bytes of it. */
#include "boot_internal.h"
#include "wdr_boot_crypto.h"
#include "wdr_err.h"
#include <string.h>

static int read_header(const wdr_boot_flash *f, uint32_t addr, uint32_t capacity, wdr_image_header *hdr)
{
    uint8_t buf[WDR_IMAGE_HEADER_SIZE];
    int rc = f->read(f->ctx, addr, buf, sizeof buf);
    if (rc == WDR_OK)
        rc = wdr_image_header_parse(buf, capacity, hdr);
    if (rc != WDR_OK)
        memset(hdr, 0, sizeof *hdr); /* only a header that parsed is handed back */
    return rc;
}

/* The application must lie in [load_lo, load_hi): u64 sums, so no field can wrap around. */
static bool load_range_ok(const wdr_image_header *h, const wdr_boot_policy *pol)
{
    return h->load_addr >= pol->load_lo && (uint64_t)h->load_addr + h->image_size <= pol->load_hi;
}

/* A trailer that is missing (a truncated image: its bytes erased or someone else's) or out of
 * range is the image's fault, WDR_E_INVAL; WDR_E_CORRUPT means "no image" (header magic). */
static int read_trailer(const wdr_boot_flash *f, uint32_t addr, wdr_image_trailer *trl)
{
    uint8_t buf[WDR_IMAGE_TRAILER_SIZE];
    int rc = f->read(f->ctx, addr, buf, sizeof buf);
    if (rc != WDR_OK)
        return rc;
    return wdr_image_trailer_parse(buf, trl) == WDR_OK ? WDR_OK : WDR_E_INVAL;
}

/* SHA-256 of len bytes of flash at addr. */
static int hash_flash(const wdr_boot_flash *f, uint32_t addr, uint32_t len, uint8_t out[WDR_SHA256_SIZE])
{
    uint8_t buf[BOOT_READ_CHUNK];
    wdr_sha256 h;
    wdr_sha256_begin(&h);
    for (uint32_t off = 0; off < len; off += BOOT_READ_CHUNK) {
        uint32_t n = len - off < BOOT_READ_CHUNK ? len - off : BOOT_READ_CHUNK;
        int rc = f->read(f->ctx, addr + off, buf, n);
        if (rc != WDR_OK)
            return rc;
        wdr_sha256_add(&h, buf, n);
    }
    wdr_sha256_end(&h, out);
    return WDR_OK;
}

/* What the trailer says against what the flash holds and the key the board trusts. */
static int check_trailer(const wdr_boot_flash *f, uint32_t addr, const wdr_image_header *hdr,
                         const wdr_boot_policy *pol, const wdr_image_trailer *trl)
{
    uint8_t digest[WDR_SHA256_SIZE], key_hash[WDR_SHA256_SIZE];
    int rc = hash_flash(f, addr, WDR_IMAGE_HEADER_SIZE + hdr->image_size, digest);
    if (rc != WDR_OK)
        return rc;
    if (memcmp(digest, trl->sha256, WDR_SHA256_SIZE))
        return WDR_E_HASH;
    wdr_sha256_of(pol->pubkey, WDR_P256_PUBKEY_SIZE, key_hash);
    if (memcmp(key_hash, trl->key_hash, WDR_SHA256_SIZE))
        return WDR_E_KEY;
    if (!pol->check_signature)
        return WDR_OK;
    rc = wdr_p256_verify(pol->pubkey, digest, trl->signature);
    return rc == WDR_E_INVAL ? WDR_E_KEY : rc; /* the embedded key is no point: trust nothing */
}

int wdr_image_verify(const wdr_boot_flash *f, uint32_t addr, uint32_t capacity, const wdr_boot_policy *pol,
                     uint32_t floor, wdr_image_header *hdr, wdr_image_trailer *trl)
{
    memset(trl, 0, sizeof *trl);
    int rc = read_header(f, addr, capacity, hdr);
    if (rc != WDR_OK)
        return rc;
    if (strncmp(hdr->board, pol->board, sizeof hdr->board))
        return WDR_E_BOARD;
    if (!load_range_ok(hdr, pol))
        return WDR_E_INVAL;
    rc = read_trailer(f, addr + WDR_IMAGE_HEADER_SIZE + hdr->image_size, trl);
    if (rc == WDR_OK)
        rc = check_trailer(f, addr, hdr, pol, trl);
    if (rc != WDR_OK)
        return rc;
    return hdr->security_counter >= floor ? WDR_OK : WDR_E_DOWNGRADE;
}
