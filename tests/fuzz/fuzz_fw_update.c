/* Target fw_update: the firmware's update commands (FW_*, REBOOT) with a fuzzed image stream,
 * on the fake board with its image flash, each reset going through the boot decision as the
 * bootloader runs it (fb_boot). The input is records, after one leading byte (reserved):
 *   0 [u16 n][n bytes]            factory: the bytes written raw into slot A, then a power-on
 *   1 [u16 n][n bytes]            a whole upload: BEGIN (n, its CRC), 1 KiB chunks, COMMIT
 *   2 [u32 len][u32 crc]          FW_BEGIN as given
 *   3 [u32 off][u16 n][n bytes]   FW_CHUNK as given
 *   4 COMMIT  5 FW_STATUS  6 CONFIRM  7 REVERT  8 REBOOT, then the reset  9 ABORT
 *   10 [u8 on]                    STREAM (needs no LUT to be refused or run)
 *   other [u16 n][n bytes]        that opcode with that payload
 * Seeds (make_seeds.c) carry images signed with the development key, so runs start past the
 * signature and the mutations reach every check after it.
 * The invariant, after every record: the firmware never marked bootable an image that fails
 * anything but the security counter (which a later confirm may legitimately raise): no slot
 * that only uploads wrote is INVALID for another reason. */
#include "crc32.h"
#include "fuzz_board.h"
#include "fuzz_input.h"
#include "wdr_boot.h"
#include "wdr_bytes.h"
#include "wdr_fw_config.h"
#include "wdr_proto.h"
#include <stdlib.h>
#include <string.h>

static wdr_fw fw;
static int raw_written[2]; /* slots written around the firmware (factory records) */

static int flash_read(void *ctx, uint32_t addr, void *buf, uint32_t len)
{
    (void)ctx;
    return hal_image_flash_read(addr, buf, len);
}

static int flash_erase(void *ctx, uint32_t block)
{
    (void)ctx;
    return hal_image_flash_erase(block);
}

static int flash_prog(void *ctx, uint32_t addr, const void *buf, uint32_t len)
{
    (void)ctx;
    return hal_image_flash_prog(addr, buf, len);
}

static wdr_boot_flash image_flash(void)
{
    wdr_boot_flash f = {{FB_IMG_BLOCK_SIZE, FB_IMG_BLOCK_COUNT, FB_IMG_PROG_SIZE}, NULL, flash_read, flash_erase,
                        flash_prog};
    return f;
}

static uint32_t slot_a_addr(void)
{
    wdr_boot_flash f = image_flash();
    wdr_boot_layout l;
    wdr_boot_layout_init(&l, &f.geo);
    return l.slot_addr[0];
}

/* A reset: the bootloader's decision, then the firmware on what it was told. */
static void reset_board(uint8_t cause)
{
    fb_power_cycle();
    fb_boot(cause);
    wdr_fw_init(&fw);
    fz_board_run(&fw, 1000);
}

static void factory(fz_input *in)
{
    size_t got;
    const uint8_t *p = fz_bytes(in, fz_u16(in), &got);
    memcpy(fb_image_flash() + slot_a_addr(), p, got);
    raw_written[0] = 1;
    reset_board(WDR_RESET_POWER_ON);
}

static void whole_upload(fz_input *in)
{
    static uint8_t pl[WDR_PROTO_MAX_PAYLOAD];
    size_t got;
    const uint8_t *p = fz_bytes(in, fz_u16(in), &got);
    wdr_put_u32(pl, (uint32_t)got);
    wdr_put_u32(pl + 4, wdr_crc32(0, p, got));
    int st = fz_board_request(&fw, WDR_CMD_FW_BEGIN, pl, WDR_BEGIN_SIZE);
    for (size_t off = 0; st == WDR_ST_OK && off < got; off += 1024) {
        size_t n = got - off < 1024 ? got - off : 1024;
        wdr_put_u32(pl, (uint32_t)off);
        memcpy(pl + 4, p + off, n);
        st = fz_board_request(&fw, WDR_CMD_FW_CHUNK, pl, (uint32_t)(4 + n));
    }
    if (st == WDR_ST_OK)
        fz_board_request(&fw, WDR_CMD_FW_COMMIT, NULL, 0);
}

static void chunk(fz_input *in)
{
    static uint8_t pl[WDR_PROTO_MAX_PAYLOAD];
    size_t got;
    uint32_t off = fz_u16(in) | (uint32_t)fz_u16(in) << 16;
    uint16_t n = fz_u16(in);
    const uint8_t *p = fz_bytes(in, n < WDR_PROTO_CHUNK_DATA_MAX ? n : WDR_PROTO_CHUNK_DATA_MAX, &got);
    wdr_put_u32(pl, off);
    memcpy(pl + 4, p, got);
    fz_board_request(&fw, WDR_CMD_FW_CHUNK, pl, (uint32_t)(4 + got));
}

static void one_record(fz_input *in, uint8_t op)
{
    static const uint8_t simple[] = {WDR_CMD_FW_COMMIT, WDR_CMD_FW_STATUS, WDR_CMD_FW_CONFIRM, WDR_CMD_FW_REVERT};
    size_t got;
    const uint8_t *p;
    switch (op) {
    case 0: factory(in); return;
    case 1: whole_upload(in); return;
    case 2: p = fz_bytes(in, WDR_BEGIN_SIZE, &got); fz_board_request(&fw, WDR_CMD_FW_BEGIN, p, (uint32_t)got); return;
    case 3: chunk(in); return;
    case 4: case 5: case 6: case 7: fz_board_request(&fw, simple[op - 4], NULL, 0); return;
    case 8:
        if (fz_board_request(&fw, WDR_CMD_REBOOT, NULL, 0) == WDR_ST_OK)
            reset_board(WDR_RESET_SOFTWARE);
        return;
    case 9: fz_board_request(&fw, WDR_CMD_ABORT, NULL, 0); return;
    case 10: p = fz_bytes(in, 1, &got); fz_board_request(&fw, WDR_CMD_STREAM, p, (uint32_t)got); return;
    default: p = fz_bytes(in, fz_u16(in), &got); fz_board_request(&fw, op, p, (uint32_t)got); return;
    }
}

/* Nothing the firmware wrote is bootable and broken (the counter aside: see the top). */
static void check_slots(void)
{
    wdr_boot_flash f = image_flash();
    wdr_boot_layout l;
    wdr_boot_policy pol = {FB_BOARD_NAME, wdr_boot_key(), WDR_FW_IMAGE_LOAD_LO, WDR_FW_IMAGE_LOAD_HI, true};
    uint32_t floor = 0;
    if (wdr_boot_layout_init(&l, &f.geo) || wdr_boot_floor_read(&f, &l, &floor))
        abort();
    for (int i = 0; i < 2; i++) {
        wdr_boot_slot s;
        if (wdr_boot_slot_read(&f, &l, i, &pol, floor, &s))
            abort();
        if (!raw_written[i] && s.state == WDR_SLOT_INVALID && s.verify_err != WDR_E_DOWNGRADE)
            abort(); /* marked pending, yet its image fails */
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    fz_input in = {data, size};
    (void)fz_u8(&in);
    raw_written[0] = raw_written[1] = 0;
    fz_board_fresh(&fw);
    for (int records = 0; in.left && records < 64; records++) {
        one_record(&in, fz_u8(&in));
        check_slots(); /* before a reboot's decision rejects what it finds broken */
    }
    reset_board(WDR_RESET_POWER_ON); /* whatever came before, the board boots and answers */
    fz_board_request(&fw, WDR_CMD_FW_STATUS, NULL, 0);
    return 0;
}
