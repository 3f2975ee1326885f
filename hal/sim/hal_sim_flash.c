/* Simulated board, flash: the NOR emulator (nor_emul.h) in RAM, optionally kept in a file
 * (sim_nor_file, also the image flash's: hal_sim_image.c).
 * Its operation counter injects a power cut (the operation torn as asked, by default half-way)
 * or an I/O failure at operation N, at the HAL boundary, as the firmware would meet them. */
#include "hal_sim_internal.h"
#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

static sim_nor_file F = {.fd = -1}; /* the table flash */

static void persist(void *ctx, uint32_t addr, uint32_t len)
{
    sim_nor_file *s = ctx;
    if (s->fd >= 0 && pwrite(s->fd, s->bytes + addr, len, addr) != (ssize_t)len)
        perror("wdr-simboard: flash file write");
}

static int load_file(sim_nor_file *s, const char *path, char *err, int errlen)
{
    size_t size = s->nor.size;
    s->fd = open(path, O_RDWR | O_CREAT | O_CLOEXEC, 0644);
    struct stat st;
    if (s->fd < 0 || fstat(s->fd, &st) < 0) {
        snprintf(err, (size_t)errlen, "%s file %s: %s", s->what, path, strerror(errno));
        return WDR_E_IO;
    }
    if (st.st_size == 0) {
        persist(s, 0, (uint32_t)size);
        return WDR_OK;
    }
    if ((size_t)st.st_size != size || pread(s->fd, s->bytes, size, 0) != (ssize_t)size) {
        snprintf(err, (size_t)errlen, "%s file %s: has %lld bytes, this board's %s has %zu", s->what, path,
                 (long long)st.st_size, s->what, size);
        return WDR_E_INVAL;
    }
    nor_emul_derive_programmed(&s->nor); /* files carry no flags */
    return WDR_OK;
}

int sim_nor_file_open(sim_nor_file *s, const hal_flash_geometry *g, const char *path, const char *what, char *err,
                      int errlen)
{
    uint64_t size = (uint64_t)g->block_size * g->block_count;
    s->what = what;
    s->fd = -1;
    if (g->prog_size > 256 || size > 0x80000000u || size == 0) {
        snprintf(err, (size_t)errlen, "bad %s geometry: block %u x %u, program unit %u", what, g->block_size,
                 g->block_count, g->prog_size);
        return WDR_E_INVAL;
    }
    s->bytes = malloc((size_t)size);
    s->programmed = g->prog_size ? calloc((size_t)size / g->prog_size, 1) : NULL;
    if (!s->bytes || !s->programmed) {
        snprintf(err, (size_t)errlen, "no memory for %llu bytes of %s", (unsigned long long)size, what);
        return WDR_E_NOMEM;
    }
    if (nor_emul_init(&s->nor, g, s->bytes, s->programmed) != WDR_OK) {
        snprintf(err, (size_t)errlen, "bad %s geometry: block %u x %u, program unit %u", what, g->block_size,
                 g->block_count, g->prog_size);
        return WDR_E_INVAL;
    }
    s->nor.changed = persist;
    s->nor.changed_ctx = s;
    return path ? load_file(s, path, err, errlen) : WDR_OK;
}

void sim_nor_file_close(sim_nor_file *s)
{
    if (s->fd >= 0)
        close(s->fd);
    free(s->bytes);
    free(s->programmed);
    memset(s, 0, sizeof *s);
    s->fd = -1;
}

int hal_sim_flash_setup(const hal_sim_config *cfg, char *err, int errlen)
{
    hal_flash_geometry g;
    g.block_size = cfg->flash_block_size ? cfg->flash_block_size : HAL_SIM_FLASH_BLOCK_SIZE;
    g.block_count = cfg->flash_block_count ? cfg->flash_block_count : HAL_SIM_FLASH_BLOCK_COUNT;
    g.prog_size = cfg->flash_prog_size ? cfg->flash_prog_size : HAL_SIM_FLASH_PROG_SIZE;
    return sim_nor_file_open(&F, &g, cfg->flash_path, "flash", err, errlen);
}

void hal_sim_flash_teardown(void) { sim_nor_file_close(&F); }

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
