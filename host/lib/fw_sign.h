/* Signed firmware images on the host (firmware/SPEC.md, "Firmware image format"): P-256 keys
 * from `openssl genpkey` (PEM), an application .bin signed into an image, and an image file
 * checked field by field, then its SHA-256, then its signature against a key. OpenSSL's
 * libcrypto does the crypto; header and trailer bytes come from firmware/boot/image.c, the
 * codec the bootloader uses. Every failure leaves in err a message naming the file, the field
 * and the value ("APP.img: header field image_size: 17 is not a multiple of 16"). */
#ifndef WDR_FW_SIGN_H
#define WDR_FW_SIGN_H
#include "wdr_image.h"
#include <stddef.h>
#include <stdint.h>

/* ---- Keys (fw_key.c) ------------------------------------------------------------------------ */

typedef struct wdr_fw_key {
    void *pkey;                          /* EVP_PKEY, owned */
    int has_private;                     /* it can sign */
    int is_dev;                          /* the tree's development key: not for production */
    uint8_t point[WDR_P256_PUBKEY_SIZE]; /* 0x04 || X || Y */
    uint8_t hash[WDR_SHA256_SIZE];       /* SHA-256 of point: the trailer's key hash */
    char name[256];                      /* the file it came from, for messages */
} wdr_fw_key;

/* Load a P-256 key from a PEM file: a private key when need_private, else a private or a
 * public one. Encrypted keys are refused (no prompt).
 * @retval WDR_OK  @retval WDR_E_IO cannot read  @retval WDR_E_INVAL not a PEM key, not P-256,
 * or public where a private one is needed (err names the file) */
int wdr_fw_key_load(const char *path, int need_private, wdr_fw_key *key, char *err, size_t cap);

/* The development key's public half (built in from firmware/boot/keys/): what `fw info` checks
 * a signature with when no key is given and the image names it. @retval WDR_OK  @retval WDR_E_INVAL */
int wdr_fw_key_load_dev(wdr_fw_key *key, char *err, size_t cap);

void wdr_fw_key_free(wdr_fw_key *key);

/* Hex of the first n bytes of p into out (2n + 1 chars). */
void wdr_fw_hex(const uint8_t *p, size_t n, char *out);

/* ---- Versions -------------------------------------------------------------------------------- */

/* "1.2.3" or "1.2.3+45": major, minor 0..255, patch 0..65535, build 0..4294967295.
 * @retval WDR_OK  @retval WDR_E_INVAL */
int wdr_fw_version_parse(const char *text, wdr_image_version *out);

/* "1.2.3+45" (no "+" part when build is 0). */
void wdr_fw_version_format(const wdr_image_version *v, char *out, size_t cap);

/* ---- Signing (fw_sign.c) ---------------------------------------------------------------------- */

typedef struct wdr_fw_sign_params {
    wdr_image_version version;
    uint32_t security_counter;
    uint32_t load_addr; /* 4-aligned */
    const char *board;  /* 1..15 printable ASCII characters */
    int ram_load;       /* WDR_IMAGE_F_RAM_LOAD: our bootloader copies every image */
} wdr_fw_sign_params;

/* Sign app (len bytes, zero padded to 16) into a whole image in *img (malloc'd, free()).
 * Flags: RAM load as asked, DEV_KEY when key is the development key. name: the application
 * file, for messages.
 * @retval WDR_OK  @retval WDR_E_INVAL a parameter out of range, an empty file, an ELF file or an
 * image already signed
 * @retval WDR_E_TOO_LARGE app over 16 MiB  @retval WDR_E_NOMEM  @retval WDR_E_SIGNATURE libcrypto failed */
int wdr_fw_sign(const char *name, const uint8_t *app, size_t len, const wdr_fw_sign_params *p, const wdr_fw_key *key,
                uint8_t **img, size_t *img_len, char *err, size_t cap);

/* ---- Checking an image (fw_verify.c) ------------------------------------------------------------ */

typedef struct wdr_fw_image_report {
    wdr_image_header hdr;
    wdr_image_trailer trl;
    uint8_t sha256[WDR_SHA256_SIZE]; /* computed over header and application */
    int hash_ok;                     /* it equals the trailer's */
    int key_checked;                 /* a key was given */
    int key_matches;                 /* the trailer's key hash is that key's */
    int signature_ok;                /* the signature verifies with that key */
    int dev_key;                     /* flagged, or its key hash is the development key's */
} wdr_fw_image_report;

/* Check an image's bytes: its structure (every field, named on failure), its SHA-256, and
 * with key (may be NULL) the key hash and the signature. name: the file, for messages.
 * @retval WDR_OK everything checked holds
 * @retval WDR_E_TRUNCATED, WDR_E_CORRUPT (magic), WDR_E_VERSION, WDR_E_INVAL, WDR_E_TOO_LARGE:
 *         structure (out->hdr and trl hold what parsed)
 * @retval WDR_E_HASH, WDR_E_KEY, WDR_E_SIGNATURE: the first check that failed (out filled) */
int wdr_fw_image_check(const char *name, const uint8_t *img, size_t len, const wdr_fw_key *key,
                       wdr_fw_image_report *out, char *err, size_t cap);

#endif
