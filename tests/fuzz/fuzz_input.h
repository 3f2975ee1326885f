/* Taking fields off a fuzzer's input, front to back; past the end everything reads as zero
 * bytes, so a harness never checks lengths itself. Header-only: every harness includes it. */
#ifndef FUZZ_INPUT_H
#define FUZZ_INPUT_H
#include <stddef.h>
#include <stdint.h>

typedef struct fz_input {
    const uint8_t *p;
    size_t left;
} fz_input;

static inline uint8_t fz_u8(fz_input *in)
{
    if (!in->left)
        return 0;
    in->left--;
    return *in->p++;
}

static inline uint16_t fz_u16(fz_input *in)
{
    uint16_t lo = fz_u8(in);
    return (uint16_t)(lo | fz_u8(in) << 8);
}

/* Up to n bytes (fewer at the end); *got says how many. */
static inline const uint8_t *fz_bytes(fz_input *in, size_t n, size_t *got)
{
    const uint8_t *p = in->p;
    *got = n < in->left ? n : in->left;
    in->p += *got;
    in->left -= *got;
    return p;
}

#endif
