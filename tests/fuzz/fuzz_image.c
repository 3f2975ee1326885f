/* Target image: the image parser, wdr_image_verify and the boot decision on a fuzzed image
 * flash (fuzz_image.h: the input is the flash's bytes, behind two control bytes). Checks what
 * must hold whatever the flash holds: a parsed header is within its bounds; a decision runs a
 * slot that verifies, in the state it says, with its ATTEMPT on flash for a test boot; nothing
 * bootable only when no slot is; the floor never falls; a cut decision repeated after the
 * reboot holds the same. */
#include "boot_test_util.h"
#include "fuzz_image.h"
#include "wdr_boot_crypto.h"
#include "wdr_err.h"
#include <stdlib.h>
#include <string.h>

static bt_flash fl;
static wdr_boot_policy pol;

static void check(int ok)
{
    if (!ok)
        abort();
}

/* The parsers straight on the input's first bytes. */
static void parse_raw(const uint8_t *p, size_t n)
{
    wdr_image_header h;
    wdr_image_trailer t;
    if (n >= WDR_IMAGE_HEADER_SIZE && wdr_image_header_parse(p, FZI_FLASH, &h) == WDR_OK)
        check(h.image_size % WDR_IMAGE_ALIGN == 0 && wdr_image_total_size(&h) <= FZI_FLASH && h.board[0]);
    if (n >= WDR_IMAGE_TRAILER_SIZE)
        wdr_image_trailer_parse(p, &t);
}

/* A slot's trailer made to match its bytes and the trusted key (FZI_FIX_HASHES). */
static void fix_hashes(int slot)
{
    uint8_t *at = fl.bytes + fl.l.slot_addr[slot];
    wdr_image_header h;
    if (wdr_image_header_parse(at, fl.l.image_capacity, &h) != WDR_OK)
        return;
    uint8_t *trl = at + WDR_IMAGE_HEADER_SIZE + h.image_size;
    wdr_image_trailer t;
    memset(&t, 0, sizeof t);
    wdr_image_trailer_parse(trl, &t);
    wdr_sha256_of(at, WDR_IMAGE_HEADER_SIZE + h.image_size, t.sha256);
    wdr_sha256_of(pol.pubkey, WDR_P256_PUBKEY_SIZE, t.key_hash);
    wdr_image_trailer_pack(&t, trl);
}

static uint32_t floor_now(void)
{
    wdr_boot_flash raw = bt_flash_raw(&fl);
    uint32_t v = 0;
    check(wdr_boot_floor_read(&raw, &fl.l, &v) == WDR_OK);
    return v;
}

static bool bootable(int state)
{
    return state == WDR_SLOT_CONFIRMED || state == WDR_SLOT_PENDING || state == WDR_SLOT_TESTING;
}

/* What the decision says, against what the flash holds after it. */
static void check_decision(const wdr_boot_decision *d, uint32_t floor_before)
{
    uint32_t floor = floor_now();
    check(floor >= floor_before && floor == d->floor);
    wdr_boot_flash raw = bt_flash_raw(&fl);
    if (d->slot < 0) {
        for (int s = 0; s < 2; s++) {
            wdr_boot_slot st;
            check(wdr_boot_slot_read(&raw, &fl.l, s, &pol, floor, &st) == WDR_OK);
            check(!bootable(st.state) || (st.state != WDR_SLOT_CONFIRMED && st.log_next >= fl.l.block_size));
        }
        return;
    }
    wdr_image_header h;
    wdr_image_trailer t;
    check(wdr_image_verify(&raw, fl.l.slot_addr[d->slot], fl.l.image_capacity, &pol, floor, &h, &t) == WDR_OK);
    const wdr_boot_slot *s = &d->slots[d->slot];
    check(d->testing ? s->state == WDR_SLOT_TESTING : s->state == WDR_SLOT_CONFIRMED);
    check(s->attempts <= WDR_BOOT_MAX_ATTEMPTS);
    if (d->testing) {
        wdr_boot_slot st;
        check(wdr_boot_slot_read(&raw, &fl.l, d->slot, &pol, floor, &st) == WDR_OK);
        check(st.state == WDR_SLOT_TESTING && st.attempts == s->attempts);
    }
}

/* One boot, checked; the decision in *d. */
static int boot(wdr_boot_decision *d)
{
    uint32_t before = floor_now();
    int rc = wdr_boot_decide(&fl.f, &fl.l, &pol, d);
    check(rc == WDR_OK || (rc == WDR_E_POWER && fl.nor.power_lost));
    if (rc == WDR_OK)
        check_decision(d, before);
    return rc;
}

static void load(const uint8_t *p, size_t n, uint8_t flags)
{
    bt_flash_init(&fl, FZI_BLOCK, FZI_BLOCKS);
    memcpy(fl.bytes, p, n < FZI_FLASH ? n : FZI_FLASH);
    nor_emul_derive_programmed(&fl.nor);
    if (flags & FZI_FIX_HASHES) {
        fix_hashes(0);
        fix_hashes(1);
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static bt_key trusted;
    if (!trusted.pkey)
        bt_key_dev(&trusted);
    pol = bt_policy(&trusted);
    uint8_t flags = size > 0 ? data[0] : 0, cut = size > 1 ? data[1] : 0;
    const uint8_t *flash = data + (size > 2 ? 2 : size);
    size_t n = size > 2 ? size - 2 : 0;
    pol.check_signature = flags & FZI_SIGNATURE;
    parse_raw(flash, n);
    load(flash, n, flags);
    for (int s = 0; s < 2; s++) {
        wdr_image_header h;
        wdr_image_trailer t;
        int rc = wdr_image_verify(&fl.f, fl.l.slot_addr[s], fl.l.image_capacity, &pol, 0, &h, &t);
        check(rc <= 0 && (rc != WDR_OK || h.header_size == WDR_IMAGE_HEADER_SIZE));
    }
    wdr_boot_decision d;
    if (cut)
        nor_emul_cut_power_at(&fl.nor, fl.nor.ops + cut, (flags >> FZI_TEAR_SHIFT) & 3);
    if (boot(&d) != WDR_OK || fl.nor.power_lost) {
        nor_emul_reboot(&fl.nor);
        nor_emul_cut_power_at(&fl.nor, 0, 0);
        check(boot(&d) == WDR_OK);
    }
    nor_emul_cut_power_at(&fl.nor, 0, 0);
    if (d.slot >= 0 && (flags & (FZI_CONFIRM | FZI_REVERT))) {
        int rc = flags & FZI_CONFIRM ? wdr_boot_confirm(&fl.f, &fl.l, &pol, d.slot)
                                     : wdr_boot_revert(&fl.f, &fl.l, &pol, d.slot);
        check(rc == WDR_OK || rc == WDR_E_STATE || rc == WDR_E_TOO_LARGE);
        check(boot(&d) == WDR_OK);
    }
    return 0;
}
