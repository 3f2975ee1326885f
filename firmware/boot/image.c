/* Image header and trailer codec (SPEC.md, "Firmware image format"): structure and bounds
 * only. Whatever comes from flash or a file is checked here before any field is used. */
#include "wdr_image.h"
#include "wdr_bytes.h"
#include "wdr_err.h"
#include <stdbool.h>
#include <string.h>

#define OFF_BOARD 32u
#define OFF_RESERVED 48u

static bool all_zero(const uint8_t *p, uint32_t n)
{
    for (uint32_t i = 0; i < n; i++)
        if (p[i])
            return false;
    return true;
}

/* A board name: printable ASCII, at least one character, NUL-terminated and NUL-padded. */
static bool board_name_ok(const uint8_t *p)
{
    uint32_t n = 0;
    while (n < WDR_IMAGE_BOARD_MAX && p[n])
        if (p[n] < 0x21u || p[n] > 0x7eu)
            return false;
        else
            n++;
    return n > 0 && n < WDR_IMAGE_BOARD_MAX && all_zero(p + n, WDR_IMAGE_BOARD_MAX - n);
}

static void read_fields(const uint8_t *p, wdr_image_header *h)
{
    h->header_size = wdr_get_u16(p + 4);
    h->format_major = p[6];
    h->format_minor = p[7];
    h->image_size = wdr_get_u32(p + 8);
    h->load_addr = wdr_get_u32(p + 12);
    h->version.major = p[16];
    h->version.minor = p[17];
    h->version.patch = wdr_get_u16(p + 18);
    h->version.build = wdr_get_u32(p + 20);
    h->security_counter = wdr_get_u32(p + 24);
    h->flags = wdr_get_u32(p + 28);
    memcpy(h->board, p + OFF_BOARD, WDR_IMAGE_BOARD_MAX);
    h->board[WDR_IMAGE_BOARD_MAX] = 0;
}

int wdr_image_header_parse(const uint8_t *p, uint32_t max_size, wdr_image_header *out)
{
    memset(out, 0, sizeof *out);
    if (wdr_get_u32(p) != WDR_IMAGE_MAGIC)
        return WDR_E_CORRUPT;
    read_fields(p, out);
    if (out->format_major != WDR_IMAGE_VERSION_MAJOR)
        return WDR_E_VERSION;
    if (out->header_size != WDR_IMAGE_HEADER_SIZE || out->image_size < WDR_IMAGE_ALIGN ||
        out->image_size % WDR_IMAGE_ALIGN || out->image_size > WDR_IMAGE_MAX_SIZE || out->load_addr % 4u ||
        (out->flags & ~WDR_IMAGE_F_KNOWN) || !board_name_ok(p + OFF_BOARD) ||
        !all_zero(p + OFF_RESERVED, WDR_IMAGE_HEADER_SIZE - OFF_RESERVED))
        return WDR_E_INVAL;
    if (wdr_image_total_size(out) > max_size)
        return WDR_E_TOO_LARGE;
    return WDR_OK;
}

void wdr_image_header_pack(const wdr_image_header *h, uint8_t *out)
{
    memset(out, 0, WDR_IMAGE_HEADER_SIZE);
    wdr_put_u32(out, WDR_IMAGE_MAGIC);
    wdr_put_u16(out + 4, WDR_IMAGE_HEADER_SIZE);
    out[6] = WDR_IMAGE_VERSION_MAJOR;
    out[7] = WDR_IMAGE_VERSION_MINOR;
    wdr_put_u32(out + 8, h->image_size);
    wdr_put_u32(out + 12, h->load_addr);
    out[16] = h->version.major;
    out[17] = h->version.minor;
    wdr_put_u16(out + 18, h->version.patch);
    wdr_put_u32(out + 20, h->version.build);
    wdr_put_u32(out + 24, h->security_counter);
    wdr_put_u32(out + 28, h->flags);
    size_t n = 0; /* strnlen is POSIX, not in the Cortex-M7 build's C library headers */
    while (n < WDR_IMAGE_BOARD_MAX - 1 && h->board[n])
        n++;
    memcpy(out + OFF_BOARD, h->board, n);
}

int wdr_image_trailer_parse(const uint8_t *p, wdr_image_trailer *out)
{
    memset(out, 0, sizeof *out);
    if (wdr_get_u32(p) != WDR_IMAGE_TRAILER_MAGIC)
        return WDR_E_CORRUPT;
    out->trailer_size = wdr_get_u16(p + 4);
    out->sig_type = wdr_get_u16(p + 6);
    if (out->trailer_size != WDR_IMAGE_TRAILER_SIZE || out->sig_type != WDR_IMAGE_SIG_ECDSA_P256)
        return WDR_E_INVAL;
    memcpy(out->sha256, p + 8, WDR_SHA256_SIZE);
    memcpy(out->key_hash, p + 40, WDR_SHA256_SIZE);
    memcpy(out->signature, p + 72, WDR_P256_SIG_SIZE);
    return WDR_OK;
}

void wdr_image_trailer_pack(const wdr_image_trailer *t, uint8_t *out)
{
    wdr_put_u32(out, WDR_IMAGE_TRAILER_MAGIC);
    wdr_put_u16(out + 4, WDR_IMAGE_TRAILER_SIZE);
    wdr_put_u16(out + 6, WDR_IMAGE_SIG_ECDSA_P256);
    memcpy(out + 8, t->sha256, WDR_SHA256_SIZE);
    memcpy(out + 40, t->key_hash, WDR_SHA256_SIZE);
    memcpy(out + 72, t->signature, WDR_P256_SIG_SIZE);
}

uint32_t wdr_image_total_size(const wdr_image_header *h)
{
    return WDR_IMAGE_HEADER_SIZE + h->image_size + WDR_IMAGE_TRAILER_SIZE;
}

int wdr_image_version_cmp(const wdr_image_version *a, const wdr_image_version *b)
{
    if (a->major != b->major)
        return a->major < b->major ? -1 : 1;
    if (a->minor != b->minor)
        return a->minor < b->minor ? -1 : 1;
    if (a->patch != b->patch)
        return a->patch < b->patch ? -1 : 1;
    if (a->build != b->build)
        return a->build < b->build ? -1 : 1;
    return 0;
}
