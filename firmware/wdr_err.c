#include "wdr_err.h"

const char *wdr_strerror(int err)
{
    switch (err) {
    case WDR_OK: return "ok";
    case WDR_E_INVAL: return "invalid value";
    case WDR_E_CORRUPT: return "corrupt (bad magic or CRC)";
    case WDR_E_VERSION: return "unsupported format version";
    case WDR_E_TRUNCATED: return "truncated";
    case WDR_E_TOO_LARGE: return "too large";
    case WDR_E_GEOMETRY: return "wrong sensor geometry";
    case WDR_E_KIND: return "wrong table kind";
    case WDR_E_NO_TABLE: return "no valid table";
    case WDR_E_IO: return "I/O error";
    case WDR_E_BUSY: return "busy";
    case WDR_E_SEQUENCE: return "out of sequence";
    case WDR_E_TIMEOUT: return "timed out";
    case WDR_E_UNSUPPORTED: return "unsupported";
    case WDR_E_NUMERIC: return "numerically unstable";
    case WDR_E_UNREALISABLE: return "not realisable as a ramp";
    case WDR_E_NOMEM: return "out of memory";
    case WDR_E_POWER: return "power lost";
    case WDR_E_SIGNATURE: return "signature does not verify";
    case WDR_E_KEY: return "signed by a key this board does not trust";
    case WDR_E_DOWNGRADE: return "security counter below the board's floor (downgrade)";
    case WDR_E_HASH: return "image hash does not match";
    case WDR_E_BOARD: return "image for another board";
    case WDR_E_STATE: return "not allowed in this state";
    case WDR_E_ABSENT: return "no board there";
    case WDR_E_DENIED: return "permission denied";
    case WDR_E_STATUS: return "refused by the board";
    case WDR_E_PROTOCOL: return "protocol violation";
    case WDR_E_FRAME: return "incomplete frame";
    default: return "unknown error";
    }
}
