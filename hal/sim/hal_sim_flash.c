/* Simulated board, flash: the NOR emulator (nor_emul.h) in RAM, optionally kept in a file.
 * Its operation counter injects a power cut (the operation torn as asked, by default half-way)
 * or an I/O failure at operation N, at the HAL boundary, as the firmware would meet them. */
#include "hal_sim_internal.h"
#include "nor_emul.h"
#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

static struct {
    nor_emul nor;
    uint8_t *bytes, *programmed;
    int fd; /* backing file, or -1 */
} F = {.fd = -1};

static void persist(void *ctx, uint32_t addr, uint32_t len)
{
    (void)ctx;
    if (F.fd >= 0 && pwrite(F.fd, F.bytes + addr, len, addr) != (ssize_t)len)
        perror("wdr-simboard: flash file write");
}

static int load_file(const char *path, char *err, int errlen)
{
    size_t size = F.nor.size;
    F.fd = open(path, O_RDWR | O_CREAT | O_CLOEXEC, 0644);
    struct stat st;
    if (F.fd < 0 || fstat(F.fd, &st) < 0) {
        snprintf(err, (size_t)errlen, "flash file %s: %s", path, strerror(errno));
        return WDR_E_IO;
    }
    if (st.st_size == 0) {
        persist(NULL, 0, (uint32_t)size);
        return WDR_OK;
    }
    if ((size_t)st.st_size != size || pread(F.fd, F.bytes, size, 0) != (ssize_t)size) {
        snprintf(err, (size_t)errlen, "flash file %s: has %lld bytes, this board's flash has %zu", path,
                 (long long)st.st_size, size);
        return WDR_E_INVAL;
    }
    nor_emul_derive_programmed(&F.nor); /* files carry no flags */
    return WDR_OK;
}

int hal_sim_flash_setup(const hal_sim_config *cfg, char *err, int errlen)
{
    hal_flash_geometry g;
    g.block_size = cfg->flash_block_size ? cfg->flash_block_size : HAL_SIM_FLASH_BLOCK_SIZE;
    g.block_count = cfg->flash_block_count ? cfg->flash_block_count : HAL_SIM_FLASH_BLOCK_COUNT;
    g.prog_size = cfg->flash_prog_size ? cfg->flash_prog_size : HAL_SIM_FLASH_PROG_SIZE;
    uint64_t size = (uint64_t)g.block_size * g.block_count;
    if (g.prog_size > 256 || size > 0x80000000u || size == 0) {
        snprintf(err, (size_t)errlen, "bad flash geometry: block %u x %u, program unit %u", g.block_size,
                 g.block_count, g.prog_size);
        return WDR_E_INVAL;
    }
    F.bytes = malloc((size_t)size);
    F.programmed = g.prog_size ? calloc((size_t)size / g.prog_size, 1) : NULL;
    if (!F.bytes || !F.programmed) {
        snprintf(err, (size_t)errlen, "no memory for %llu bytes of flash", (unsigned long long)size);
        return WDR_E_NOMEM;
    }
    if (nor_emul_init(&F.nor, &g, F.bytes, F.programmed) != WDR_OK) {
        snprintf(err, (size_t)errlen, "bad flash geometry: block %u x %u, program unit %u", g.block_size,
                 g.block_count, g.prog_size);
        return WDR_E_INVAL;
    }
    F.nor.changed = persist;
    F.fd = -1;
    return cfg->flash_path ? load_file(cfg->flash_path, err, errlen) : WDR_OK;
}

void hal_sim_flash_teardown(void)
{
    if (F.fd >= 0)
        close(F.fd);
    free(F.bytes);
    free(F.programmed);
    memset(&F, 0, sizeof F);
    F.fd = -1;
}

void hal_sim_flash_reboot(void) { nor_emul_reboot(&F.nor); }

/* ---- The HAL functions ------------------------------------------------------------------ */

int hal_flash_geometry_get(hal_flash_geometry *g)
{
    if (!F.bytes)
        return WDR_E_IO;
    *g = F.nor.g;
    return WDR_OK;
}

int hal_flash_read(uint32_t addr, void *buf, uint32_t len) { return nor_emul_read(&F.nor, addr, buf, len); }
int hal_flash_erase(uint32_t block) { return nor_emul_erase(&F.nor, block); }
int hal_flash_prog(uint32_t addr, const void *buf, uint32_t len) { return nor_emul_prog(&F.nor, addr, buf, len); }

/* ---- Emulator control: n counts from now (1 = the next operation) ------------------------ */

void hal_sim_cut_power_at(uint64_t n) { hal_sim_cut_power_tear(n, NOR_TEAR_FIRST_HALF); }

void hal_sim_cut_power_tear(uint64_t n, int tear) { nor_emul_cut_power_at(&F.nor, n ? F.nor.ops + n : 0, tear); }

void hal_sim_fail_flash_at(uint64_t n) { nor_emul_fail_at(&F.nor, n ? F.nor.ops + n : 0); }

uint64_t hal_sim_flash_ops(void) { return F.nor.ops; }

int hal_sim_power_lost(void) { return F.nor.power_lost; }

void hal_sim_flash_reset(void)
{
    if (F.bytes)
        nor_emul_erase_all(&F.nor);
}

const uint8_t *hal_sim_flash_bytes(size_t *size)
{
    *size = F.nor.size;
    return F.bytes;
}
