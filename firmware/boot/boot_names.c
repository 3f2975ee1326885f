/* Short English names of slot states and reset causes, for messages and fw status. */
#include "wdr_boot.h"

const char *wdr_slot_state_name(int state)
{
    switch (state) {
    case WDR_SLOT_EMPTY: return "empty";
    case WDR_SLOT_INCOMPLETE: return "incomplete";
    case WDR_SLOT_PENDING: return "pending";
    case WDR_SLOT_TESTING: return "testing";
    case WDR_SLOT_CONFIRMED: return "confirmed";
    case WDR_SLOT_REJECTED: return "rejected";
    case WDR_SLOT_INVALID: return "invalid";
    default: return "unknown";
    }
}

const char *wdr_reset_cause_name(int cause)
{
    switch (cause) {
    case WDR_RESET_POWER_ON: return "power-on";
    case WDR_RESET_SOFTWARE: return "software";
    case WDR_RESET_WATCHDOG: return "watchdog";
    case WDR_RESET_FAULT: return "fault";
    default: return "unknown";
    }
}
