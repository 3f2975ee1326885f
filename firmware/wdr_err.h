/* One error enum for the whole project: every failure is a negative code. */
#ifndef WDR_ERR_H
#define WDR_ERR_H

enum wdr_err {
    WDR_OK = 0,
    WDR_E_INVAL = -1,      /* bad argument or field value */
    WDR_E_CORRUPT = -2,    /* CRC or magic mismatch */
    WDR_E_VERSION = -3,    /* unsupported format version */
    WDR_E_TRUNCATED = -4,  /* fewer bytes than the header promises */
    WDR_E_TOO_LARGE = -5,  /* does not fit the buffer or slot */
    WDR_E_GEOMETRY = -6,   /* sensor id, width or height mismatch */
    WDR_E_KIND = -7,       /* wrong table kind */
    WDR_E_NO_TABLE = -8,   /* no valid table stored */
    WDR_E_IO = -9,         /* HAL or OS I/O failure */
    WDR_E_BUSY = -10,      /* operation in progress */
    WDR_E_SEQUENCE = -11,  /* packet or chunk out of order */
    WDR_E_TIMEOUT = -12,   /* peer did not answer in time */
    WDR_E_UNSUPPORTED = -13,
    WDR_E_NUMERIC = -14,   /* NaN, Inf or ill-conditioned maths */
    WDR_E_UNREALISABLE = -15, /* operator cannot be realised as a ramp */
    WDR_E_NOMEM = -16,     /* host-side allocation failed */
    WDR_E_POWER = -17,     /* simulated power cut */
    /* firmware images (firmware/boot) */
    WDR_E_SIGNATURE = -18, /* the image's signature does not verify */
    WDR_E_KEY = -19,       /* the image is signed by a key this board does not trust */
    WDR_E_DOWNGRADE = -20, /* the image's security counter is below the board's floor */
    WDR_E_HASH = -21,      /* the image's SHA-256 differs from its trailer's */
    WDR_E_BOARD = -22,     /* the image is for another board */
    WDR_E_STATE = -23,     /* not allowed in this state (confirm with nothing to confirm, ...) */
    /* host-only outcomes of reaching a board (host/lib/transport*) */
    WDR_E_ABSENT = -64,    /* no board at that address (no socket, no listener, no USB device) */
    WDR_E_DENIED = -65,    /* the OS refused access (USB permissions: install the udev rule) */
    WDR_E_STATUS = -66,    /* the board answered with a non-OK status */
    WDR_E_PROTOCOL = -67,  /* the board answered something the protocol does not allow */
    WDR_E_FRAME = -68      /* a frame whose rows did not each arrive once (duplicate, missing, out of range) */
};

/* Short English name of an error code, for messages. */
const char *wdr_strerror(int err);

#endif
