/* Test-only helpers for the boot chain's tests (test_boot_*.c, tests/powerloss, tests/fuzz): an
 * image flash over the NOR emulator, and images signed with OpenSSL's libcrypto (never the
 * host tool: these tests must hold even if `wdrctl fw sign` is wrong). Keys: the tree's
 * development key (NOT FOR PRODUCTION) and keys generated on the fly ("another key"). */
#ifndef BOOT_TEST_UTIL_H
#define BOOT_TEST_UTIL_H
#include "nor_emul.h"
#include "wdr_boot.h"
#include <stddef.h>
#include <stdint.h>

#define BT_MAX_FLASH (512u * 1024u)
#define BT_BOARD "sim-vga"
#define BT_LOAD_LO 0x20000000u
#define BT_LOAD_HI 0x20100000u

/* An image flash: the NOR emulator, its wdr_boot_flash and layout. */
typedef struct bt_flash {
    nor_emul nor;
    uint8_t bytes[BT_MAX_FLASH];
    uint8_t programmed[BT_MAX_FLASH / 16];
    wdr_boot_flash f;
    wdr_boot_layout l;
} bt_flash;

/* Erased flash of block_count blocks of block_size bytes, 16-byte program unit; fails the test
 * process (abort) on a geometry the layout refuses. */
void bt_flash_init(bt_flash *b, uint32_t block_size, uint32_t block_count);
/* The same flash seen without the emulator's power state (reads always work): what a checker
 * reads after a cut, before the reboot. */
wdr_boot_flash bt_flash_raw(bt_flash *b);

typedef struct bt_key {
    void *pkey;                         /* EVP_PKEY */
    uint8_t pub[WDR_P256_PUBKEY_SIZE];  /* uncompressed point */
} bt_key;

/* The tree's development key (firmware/boot/keys/), or a fresh P-256 key. Abort on failure. */
void bt_key_dev(bt_key *k);
void bt_key_generate(bt_key *k);

typedef struct bt_image_spec {
    wdr_image_version version;
    uint32_t counter, load_addr, app_size, flags;
    const char *board;          /* NULL: BT_BOARD */
    uint8_t seed;               /* application bytes: a pattern from it */
} bt_image_spec;

/* A default spec: version 1.0.0 build 1, counter 1, RAM load at BT_LOAD_LO, 2048 bytes. */
bt_image_spec bt_spec(uint8_t major, uint32_t counter, uint32_t app_size);

/* Build the image: header, application, trailer with the SHA-256, the hash of hash_key's
 * public point (NULL: signer's) and signer's signature. Returns its bytes; aborts when it
 * does not fit cap. */
size_t bt_image_build(uint8_t *out, size_t cap, const bt_image_spec *s, const bt_key *signer,
                      const bt_key *hash_key);

/* Program an image at a slot as a factory would (no log records): erase its blocks, write. */
void bt_flash_image(bt_flash *b, int slot, const uint8_t *img, size_t len);

/* A whole upload through the library (begin, chunks of `chunk` bytes, finish): the first
 * error of a step, or WDR_OK. */
int bt_upload(bt_flash *b, int slot, const uint8_t *img, size_t len, uint32_t chunk, const wdr_boot_policy *pol);

/* Policy for BT_BOARD, the load range above and the public key. */
wdr_boot_policy bt_policy(const bt_key *trusted);

#endif
