/* Confirm and revert: one record on the running slot (SPEC.md, "Confirm", "Revert"). */
#include "boot_internal.h"
#include "wdr_err.h"

int wdr_boot_confirm(const wdr_boot_flash *f, const wdr_boot_layout *l, const wdr_boot_policy *pol, int slot)
{
    if (!boot_slot_ok(slot))
        return WDR_E_INVAL;
    uint32_t floor;
    wdr_boot_slot s;
    int rc = wdr_boot_floor_read(f, l, &floor);
    if (rc == WDR_OK)
        rc = wdr_boot_slot_read(f, l, slot, pol, floor, &s);
    if (rc != WDR_OK)
        return rc;
    if (s.state == WDR_SLOT_PENDING || s.state == WDR_SLOT_TESTING)
        rc = wdr_boot_log_append(f, l, slot, WDR_REC_CONFIRMED, 0);
    else if (s.state != WDR_SLOT_CONFIRMED)
        return WDR_E_STATE;
    /* The floor only after CONFIRMED: a cut between leaves a confirmed image and the old floor,
     * which the next boot raises (boot_decide.c), never a floor the running image is below. */
    if (rc == WDR_OK)
        rc = wdr_boot_floor_raise(f, l, s.hdr.security_counter);
    return rc;
}

int wdr_boot_revert(const wdr_boot_flash *f, const wdr_boot_layout *l, const wdr_boot_policy *pol, int running)
{
    if (!boot_slot_ok(running))
        return WDR_E_INVAL;
    uint32_t floor;
    wdr_boot_slot other;
    int rc = wdr_boot_floor_read(f, l, &floor);
    if (rc == WDR_OK)
        rc = wdr_boot_slot_read(f, l, 1 - running, pol, floor, &other);
    if (rc != WDR_OK)
        return rc;
    if (other.state != WDR_SLOT_CONFIRMED)
        return WDR_E_STATE; /* the board would boot nothing, or an image nobody confirmed */
    return wdr_boot_log_append(f, l, running, WDR_REC_REJECTED, WDR_REJECT_REVERTED);
}
