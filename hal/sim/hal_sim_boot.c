/* Simulated board, the boot: what the bootloader does at every reset, with the same logic
 * compiled for the host (firmware/boot, wdr_boot_decide) over the image flash, then the boot
 * record it leaves for the application; hal_reset, which makes the board reboot once the
 * firmware's task returns; and a watchdog that is fed but never expires (virtual time stops
 * when the firmware waits, so it could not tell a hang from an idle board). */
#include "hal_sim_internal.h"
#include "wdr_boot.h"
#include "wdr_fw_config.h"
#include <stdio.h>
#include <string.h>

static struct {
    int has_record;
    wdr_boot_record record;
    int note;            /* cause hal_reset left for the next boot, -1: none (power-on) */
    uint32_t boots;      /* boots since setup */
    int reset_pending;
    int log;
    uint64_t feeds;
} S = {.note = -1};

static int img_read(void *ctx, uint32_t addr, void *buf, uint32_t len)
{
    return nor_emul_read(ctx, addr, buf, len);
}

static int img_erase(void *ctx, uint32_t block) { return nor_emul_erase(ctx, block); }

static int img_prog(void *ctx, uint32_t addr, const void *buf, uint32_t len)
{
    return nor_emul_prog(ctx, addr, buf, len);
}

static void log_boot(const wdr_boot_decision *d, int err)
{
    if (!S.log)
        return;
    if (err || d->slot < 0) {
        fprintf(stderr, "wdr-simboard: boot %u: %s: running the built-in firmware unversioned (fw status: not "
                "booted)\n", S.boots, err ? wdr_strerror(err) : "no bootable image");
        return;
    }
    const wdr_image_header *h = &d->slots[d->slot].hdr;
    fprintf(stderr, "wdr-simboard: boot %u: slot %c, v%u.%u.%u+%u%s\n", S.boots, 'A' + d->slot, h->version.major,
            h->version.minor, h->version.patch, h->version.build,
            d->testing ? " (test boot: confirm it or it reverts)" : "");
}

static void fill_record(const wdr_boot_decision *d, int cause)
{
    wdr_boot_record *r = &S.record;
    memset(r, 0, sizeof *r);
    r->magic = WDR_BOOT_RECORD_MAGIC_RAM;
    r->slot = (uint8_t)d->slot;
    r->testing = d->testing;
    r->attempts = d->slots[d->slot].attempts;
    r->reset_cause = (uint8_t)cause;
    r->boots = S.boots;
    r->floor = d->floor;
    r->hdr = d->slots[d->slot].hdr;
    wdr_boot_record_seal(r);
    S.has_record = 1;
}

/* The bootloader's part of hal_init: decide, record, consume the reset note. */
void hal_sim_boot_run(void)
{
    const nor_emul *nor = hal_sim_image_nor();
    wdr_boot_flash f = {nor->g, (void *)nor, img_read, img_erase, img_prog};
    wdr_boot_layout l;
    wdr_boot_decision d;
    hal_board_info b;
    int cause = S.note < 0 ? WDR_RESET_POWER_ON : S.note;
    S.note = -1;
    S.has_record = 0;
    S.boots++;
    int err = hal_board_info_get(&b);
    if (!err)
        err = wdr_boot_layout_init(&l, &f.geo);
    wdr_boot_policy pol = {b.name, wdr_boot_key(), WDR_FW_IMAGE_LOAD_LO, WDR_FW_IMAGE_LOAD_HI, true};
    if (!err)
        err = wdr_boot_decide(&f, &l, &pol, &d);
    if (!err && d.slot >= 0)
        fill_record(&d, cause);
    log_boot(&d, err);
}

void hal_sim_boot_teardown(void)
{
    memset(&S, 0, sizeof S);
    S.note = -1;
}

/* ---- The HAL functions ------------------------------------------------------------------ */

int hal_boot_record_get(struct wdr_boot_record *out)
{
    if (!S.has_record || !wdr_boot_record_ok(&S.record))
        return WDR_E_UNSUPPORTED;
    *out = S.record;
    return WDR_OK;
}

void hal_reset(uint8_t cause)
{
    S.note = cause;
    S.reset_pending = 1;
}

void hal_watchdog_feed(void) { S.feeds++; }

/* ---- Emulator control ------------------------------------------------------------------- */

void hal_sim_set_boot_log(int on) { S.log = on; }

int hal_sim_take_reset(void)
{
    int r = S.reset_pending;
    S.reset_pending = 0;
    return r;
}

uint64_t hal_sim_watchdog_feeds(void) { return S.feeds; }
