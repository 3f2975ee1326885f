/* Signed firmware image format (SPEC.md, "Firmware image format"): a 64-byte header, the
 * application bytes, then a trailer with the SHA-256 of header and application, the hash of
 * the signing key and an ECDSA P-256 signature. Parsing here is structure only (no crypto, no
 * HAL): every field bounded before use. Shared by the bootloader, the firmware and the host. */
#ifndef WDR_IMAGE_H
#define WDR_IMAGE_H
#include <stddef.h>
#include <stdint.h>

#define WDR_IMAGE_MAGIC 0x474d4957u         /* "WIMG" in memory order */
#define WDR_IMAGE_TRAILER_MAGIC 0x4c544957u /* "WITL" */
#define WDR_IMAGE_VERSION_MAJOR 1
#define WDR_IMAGE_VERSION_MINOR 0
#define WDR_IMAGE_HEADER_SIZE 64u
#define WDR_IMAGE_TRAILER_SIZE 136u
#define WDR_IMAGE_ALIGN 16u                 /* image_size is a multiple of it (zero padded) */
#define WDR_IMAGE_MAX_SIZE (16u << 20)      /* no board holds more; a slot's capacity is lower */
#define WDR_IMAGE_BOARD_MAX 16u             /* board name bytes, NUL padded */
#define WDR_IMAGE_SIG_ECDSA_P256 1u         /* sig_type: ECDSA P-256 over SHA-256, raw r || s */
#define WDR_SHA256_SIZE 32u
#define WDR_P256_PUBKEY_SIZE 65u            /* uncompressed point: 0x04 || X || Y */
#define WDR_P256_SIG_SIZE 64u

/* flags */
#define WDR_IMAGE_F_RAM_LOAD 0x1u     /* the bootloader copies the application to load_addr */
#define WDR_IMAGE_F_DEV_KEY 0x2u      /* signed with the tree's development key: not for production */
#define WDR_IMAGE_F_KNOWN 0x3u        /* other bits are reserved, zero */

typedef struct wdr_image_version {
    uint8_t major, minor;
    uint16_t patch;
    uint32_t build;
} wdr_image_version;

typedef struct wdr_image_header {
    uint16_t header_size;        /* WDR_IMAGE_HEADER_SIZE */
    uint8_t format_major, format_minor;
    uint32_t image_size;         /* application bytes after the header, multiple of 16 */
    uint32_t load_addr;          /* where the application runs (its vector table) */
    wdr_image_version version;
    uint32_t security_counter;   /* anti-rollback: never boots below the board's floor */
    uint32_t flags;              /* WDR_IMAGE_F_* */
    char board[WDR_IMAGE_BOARD_MAX + 1]; /* NUL-terminated board name */
} wdr_image_header;

typedef struct wdr_image_trailer {
    uint16_t trailer_size;       /* WDR_IMAGE_TRAILER_SIZE */
    uint16_t sig_type;           /* WDR_IMAGE_SIG_ECDSA_P256 */
    uint8_t sha256[WDR_SHA256_SIZE];   /* of the header and application bytes */
    uint8_t key_hash[WDR_SHA256_SIZE]; /* SHA-256 of the 65-byte public key */
    uint8_t signature[WDR_P256_SIG_SIZE];
} wdr_image_trailer;

/* Parse and bound-check a header from 64 bytes. max_size: the slot's capacity for the whole
 * image (header + application + trailer).
 * @retval WDR_OK  @retval WDR_E_CORRUPT bad magic  @retval WDR_E_VERSION other major
 * @retval WDR_E_INVAL a field out of range (header size, alignment, flags, board name, reserved)
 * @retval WDR_E_TOO_LARGE the image does not fit max_size */
int wdr_image_header_parse(const uint8_t *p, uint32_t max_size, wdr_image_header *out);

/* Write h as 64 header bytes (reserved bytes zero). */
void wdr_image_header_pack(const wdr_image_header *h, uint8_t *out);

/* Parse a trailer from 136 bytes. @retval WDR_OK  @retval WDR_E_CORRUPT bad magic
 * @retval WDR_E_INVAL size or signature type unknown */
int wdr_image_trailer_parse(const uint8_t *p, wdr_image_trailer *out);
void wdr_image_trailer_pack(const wdr_image_trailer *t, uint8_t *out);

/* Bytes of the whole image: header + application + trailer. */
uint32_t wdr_image_total_size(const wdr_image_header *h);

/* Compare versions: <0, 0, >0 as a is older, equal, newer than b (major, minor, patch, build). */
int wdr_image_version_cmp(const wdr_image_version *a, const wdr_image_version *b);

#endif
