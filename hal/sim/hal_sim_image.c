/* Simulated board, image flash: a second NOR emulator beside the table flash, with the
 * mps2-an500's geometry, kept in its own file when asked (wdr-simboard: FLASH.images), and the
 * factory write of a blank board. */
#include "hal_sim_internal.h"
#include "wdr_boot.h"
#include <string.h>

static sim_nor_file I = {.fd = -1};

int hal_sim_image_setup(const hal_sim_config *cfg, char *err, int errlen)
{
    const hal_flash_geometry g = {HAL_SIM_IMAGE_BLOCK_SIZE, HAL_SIM_IMAGE_BLOCK_COUNT, HAL_SIM_IMAGE_PROG_SIZE};
    return sim_nor_file_open(&I, &g, cfg->image_flash_path, "image flash", err, errlen);
}

void hal_sim_image_teardown(void) { sim_nor_file_close(&I); }

void hal_sim_image_reboot(void)
{
    if (I.bytes)
        nor_emul_reboot(&I.nor);
}

const nor_emul *hal_sim_image_nor(void) { return &I.nor; }

/* ---- The HAL functions ------------------------------------------------------------------ */

int hal_image_flash_geometry_get(hal_flash_geometry *g)
{
    if (!I.bytes)
        return WDR_E_UNSUPPORTED;
    *g = I.nor.g;
    return WDR_OK;
}

int hal_image_flash_read(uint32_t addr, void *buf, uint32_t len)
{
    return I.bytes ? nor_emul_read(&I.nor, addr, buf, len) : WDR_E_UNSUPPORTED;
}

int hal_image_flash_erase(uint32_t block) { return I.bytes ? nor_emul_erase(&I.nor, block) : WDR_E_UNSUPPORTED; }

int hal_image_flash_prog(uint32_t addr, const void *buf, uint32_t len)
{
    return I.bytes ? nor_emul_prog(&I.nor, addr, buf, len) : WDR_E_UNSUPPORTED;
}

/* ---- Emulator control ------------------------------------------------------------------- */

int hal_sim_image_flash_blank(void)
{
    for (size_t i = 0; I.bytes && i < I.nor.size; i++)
        if (I.bytes[i] != 0xFF)
            return 0;
    return 1;
}

/* Block by block from slot A's first byte, the last program unit padded with 0xFF. */
int hal_sim_image_flash_write_factory(const uint8_t *image, size_t len)
{
    wdr_boot_layout l;
    if (!I.bytes || wdr_boot_layout_init(&l, &I.nor.g) != WDR_OK)
        return WDR_E_IO;
    if (len == 0 || len > l.image_capacity)
        return WDR_E_TOO_LARGE;
    uint32_t bs = I.nor.g.block_size, unit = I.nor.g.prog_size;
    uint8_t buf[HAL_SIM_IMAGE_BLOCK_SIZE];
    for (uint32_t off = 0; off < len; off += bs) {
        uint32_t n = len - off < bs ? (uint32_t)(len - off) : bs, padded = (n + unit - 1) / unit * unit;
        memset(buf, 0xFF, sizeof buf);
        memcpy(buf, image + off, n);
        int err = nor_emul_erase(&I.nor, (l.slot_addr[0] + off) / bs);
        if (!err)
            err = nor_emul_prog(&I.nor, l.slot_addr[0] + off, buf, padded);
        if (err)
            return err;
    }
    return WDR_OK;
}

uint8_t *hal_sim_image_flash_bytes(size_t *size)
{
    *size = I.nor.size;
    return I.bytes;
}
