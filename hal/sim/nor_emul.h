/* One strict NOR-flash emulator, for the simulated board (hal_sim_flash.c) and the firmware
 * tests' fake board (tests/firmware/fake_hal.c): erase sets a block to 0xFF; a program needs
 * prog_size alignment and units untouched since their erase (never ANDed in). Operations are
 * counted one way everywhere: every erase and program tried while powered, with valid
 * arguments, counts once, whether it succeeds, is cut or fails; reads never count; the count
 * runs from nor_emul_init and survives reboots. A fault is armed for one operation number:
 * a power cut (with the shape of the tear it leaves) or an I/O error (flash untouched).
 * No heap and no OS: the caller owns the buffers. */
#ifndef NOR_EMUL_H
#define NOR_EMUL_H
#include "hal.h"
#include <stddef.h>
#include <stdint.h>

/* What the operation a power cut interrupts leaves behind. */
enum nor_tear {
    NOR_TEAR_NONE = 0,        /* nothing done */
    NOR_TEAR_FIRST_HALF = 1,  /* its first half done (the bytes or the block's first half) */
    NOR_TEAR_SECOND_HALF = 2, /* its second half done */
    NOR_TEAR_BITS = 3         /* every byte partly done: a program cleared only some of its 0 bits
                                 (bits 0, 2, 4, 6), an erase set only some to 1 (bits 1, 3, 5, 7) */
};

typedef struct nor_emul {
    hal_flash_geometry g;
    uint8_t *bytes;       /* block_size * block_count */
    uint8_t *programmed;  /* one flag per program unit since its last erase */
    size_t size;
    uint64_t ops;         /* operations counted since nor_emul_init */
    uint64_t cut_at, fail_at; /* operation numbers (1 = the first) of the armed faults; 0: none */
    int tear;             /* enum nor_tear of the armed cut */
    int power_lost;
    /* Called with every range that changed (a backing file); may be NULL. */
    void (*changed)(void *ctx, uint32_t addr, uint32_t len);
    void *changed_ctx;
} nor_emul;

/* Erased flash of geometry g over the caller's buffers (bytes: block_size * block_count,
 * programmed: that / prog_size). @retval WDR_OK, WDR_E_INVAL (sizes not powers of two,
 * prog_size > block_size) */
int nor_emul_init(nor_emul *f, const hal_flash_geometry *g, uint8_t *bytes, uint8_t *programmed);

/* Recompute the programmed flags from the bytes (a unit with any byte not 0xFF), after the
 * bytes were loaded or changed from outside. */
void nor_emul_derive_programmed(nor_emul *f);

/* The hal.h flash functions over f. */
int nor_emul_read(const nor_emul *f, uint32_t addr, void *buf, uint32_t len);
int nor_emul_erase(nor_emul *f, uint32_t block);
int nor_emul_prog(nor_emul *f, uint32_t addr, const void *buf, uint32_t len);

/* Cut power at operation number op (counted as nor_emul.ops will count it; 0 disarms); the
 * cut operation leaves `tear`, and it and every later call return WDR_E_POWER until reboot. */
void nor_emul_cut_power_at(nor_emul *f, uint64_t op, int tear);
/* Make operation number op fail with WDR_E_IO, flash untouched (0 disarms). */
void nor_emul_fail_at(nor_emul *f, uint64_t op);
/* Power back: flash keeps its bytes; armed faults stay armed. */
void nor_emul_reboot(nor_emul *f);
/* Erase everything (a factory-new chip). */
void nor_emul_erase_all(nor_emul *f);

#endif
