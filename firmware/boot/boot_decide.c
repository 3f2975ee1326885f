/* The bootloader's decision at every reset (SPEC.md, "Boot decision"). Records first, then
 * the answer: a cut before the answer repeats a decision at least as safe. A record the flash
 * refuses (its log full, or the program failing) makes the decision more careful, never stops
 * it: a worn state block must not leave a board that boots nothing. */
#include "boot_internal.h"
#include "wdr_err.h"

/* The record could not be written, but power is still there: decide without it. */
static bool refused(int rc) { return rc == WDR_E_TOO_LARGE || rc == WDR_E_IO; }

/* REJECTED into a slot's log; when the flash refuses it, the slot is not booted now either,
 * and the next boot finds the same. */
static int reject(const wdr_boot_flash *f, const wdr_boot_layout *l, int s, uint8_t reason, wdr_boot_slot *slot)
{
    int rc = boot_log_put(f, l->state_addr[s], l->block_size, slot->log_next, WDR_REC_REJECTED, reason);
    if (rc != WDR_OK && !refused(rc))
        return rc;
    if (rc == WDR_OK)
        slot->log_next += WDR_BOOT_RECORD_SIZE;
    slot->state = WDR_SLOT_REJECTED;
    slot->reject_reason = reason;
    return WDR_OK;
}

static bool on_test(const wdr_boot_slot *s) { return s->state == WDR_SLOT_PENDING || s->state == WDR_SLOT_TESTING; }

/* Give up what fails or has used its test boots. */
static int reject_unbootable(const wdr_boot_flash *f, const wdr_boot_layout *l, wdr_boot_decision *d)
{
    for (int s = 0; s < 2; s++) {
        int rc = WDR_OK;
        if (d->slots[s].state == WDR_SLOT_INVALID)
            rc = reject(f, l, s, WDR_REJECT_INVALID, &d->slots[s]);
        else if (on_test(&d->slots[s]) && d->slots[s].attempts >= WDR_BOOT_MAX_ATTEMPTS)
            rc = reject(f, l, s, WDR_REJECT_UNCONFIRMED, &d->slots[s]);
        if (rc != WDR_OK)
            return rc;
    }
    return WDR_OK;
}

/* Of the slots in state `state`, the newer version (A on a tie); -1 when neither. */
static int newest(const wdr_boot_decision *d, int state)
{
    bool a = d->slots[0].state == state, b = d->slots[1].state == state;
    if (a && b)
        return wdr_image_version_cmp(&d->slots[1].hdr.version, &d->slots[0].hdr.version) > 0 ? 1 : 0;
    return a ? 0 : b ? 1 : -1;
}

static int newest_on_test(const wdr_boot_decision *d)
{
    int p = newest(d, WDR_SLOT_PENDING), t = newest(d, WDR_SLOT_TESTING);
    if (p < 0 || t < 0)
        return p < 0 ? t : p;
    return wdr_image_version_cmp(&d->slots[p].hdr.version, &d->slots[t].hdr.version) > 0 ? p : t;
}

/* A test boot: its ATTEMPT is on flash before the decision says so. A slot whose ATTEMPT the
 * flash refuses is passed over (never booted uncounted), and the other one, if on test, tried. */
static int try_test_boot(const wdr_boot_flash *f, const wdr_boot_layout *l, wdr_boot_decision *d)
{
    for (int s; (s = newest_on_test(d)) >= 0;) {
        wdr_boot_slot *slot = &d->slots[s];
        int rc = boot_log_put(f, l->state_addr[s], l->block_size, slot->log_next, WDR_REC_ATTEMPT, slot->attempts + 1u);
        if (refused(rc)) {
            slot->state = WDR_SLOT_REJECTED; /* for this decision only: it cannot be counted */
            continue;
        }
        if (rc != WDR_OK)
            return rc;
        slot->log_next += WDR_BOOT_RECORD_SIZE;
        slot->attempts++;
        slot->state = WDR_SLOT_TESTING;
        d->slot = s;
        d->testing = true;
        return WDR_OK;
    }
    return WDR_OK;
}

/* A confirmed image runs; the floor follows it (a confirm cut between its CONFIRMED record and
 * its floor raise is completed here; a factory image sets the first floor). */
static int confirmed_boot(const wdr_boot_flash *f, const wdr_boot_layout *l, wdr_boot_decision *d)
{
    int s = newest(d, WDR_SLOT_CONFIRMED);
    if (s < 0)
        return WDR_OK;
    uint32_t counter = d->slots[s].hdr.security_counter;
    if (counter > d->floor) {
        int rc = wdr_boot_floor_raise(f, l, counter);
        if (rc != WDR_OK && rc != WDR_E_IO)
            return rc;
        if (rc == WDR_OK) /* else the next boot raises it: the image is confirmed either way */
            d->floor = counter;
    }
    d->slot = s;
    return WDR_OK;
}

int wdr_boot_decide(const wdr_boot_flash *f, const wdr_boot_layout *l, const wdr_boot_policy *pol,
                    wdr_boot_decision *out)
{
    *out = (wdr_boot_decision){.slot = -1};
    int rc = wdr_boot_floor_read(f, l, &out->floor);
    for (int s = 0; s < 2 && rc == WDR_OK; s++)
        rc = wdr_boot_slot_read(f, l, s, pol, out->floor, &out->slots[s]);
    if (rc == WDR_OK)
        rc = reject_unbootable(f, l, out);
    if (rc == WDR_OK)
        rc = try_test_boot(f, l, out);
    if (rc == WDR_OK && out->slot < 0)
        rc = confirmed_boot(f, l, out);
    if (rc != WDR_OK)
        out->slot = -1;
    return rc;
}
