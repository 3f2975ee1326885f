/* Simulated board, flash: a strict NOR emulator in RAM, optionally kept in a file.
 * Erase sets a block to 0xFF; program needs prog_size alignment and units untouched since their
 * erase. An operation counter injects a power cut (the operation is torn half-way) or an I/O
 * failure at operation N, at the HAL boundary, as the firmware would meet them. */
#include "hal_sim_internal.h"
#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

static struct {
    hal_flash_geometry g;
    uint8_t *bytes;
    uint8_t *programmed; /* one flag per program unit since its last erase */
    size_t size;
    int fd;              /* backing file, or -1 */
    uint64_t ops;        /* erases and programs so far */
    uint64_t cut_at, fail_at; /* absolute op numbers, 0 when disarmed */
    int power_lost;
} F = {.fd = -1};

static int is_pow2(uint32_t x) { return x && !(x & (x - 1)); }

static void persist(uint32_t addr, uint32_t len)
{
    if (F.fd >= 0 && pwrite(F.fd, F.bytes + addr, len, addr) != (ssize_t)len)
        perror("wdr-simboard: flash file write");
}

/* A unit counts as programmed if any byte left the erased state (files carry no flags). */
static void derive_programmed(void)
{
    for (size_t u = 0; u < F.size / F.g.prog_size; u++) {
        const uint8_t *p = F.bytes + u * F.g.prog_size;
        F.programmed[u] = 0;
        for (uint32_t i = 0; i < F.g.prog_size && !F.programmed[u]; i++)
            F.programmed[u] = p[i] != 0xFF;
    }
}

static int load_file(const char *path, char *err, int errlen)
{
    F.fd = open(path, O_RDWR | O_CREAT | O_CLOEXEC, 0644);
    struct stat st;
    if (F.fd < 0 || fstat(F.fd, &st) < 0) {
        snprintf(err, (size_t)errlen, "flash file %s: %s", path, strerror(errno));
        return WDR_E_IO;
    }
    if (st.st_size == 0) {
        persist(0, (uint32_t)F.size);
        return WDR_OK;
    }
    if ((size_t)st.st_size != F.size || pread(F.fd, F.bytes, F.size, 0) != (ssize_t)F.size) {
        snprintf(err, (size_t)errlen, "flash file %s: has %lld bytes, this board's flash has %zu", path,
                 (long long)st.st_size, F.size);
        return WDR_E_INVAL;
    }
    derive_programmed();
    return WDR_OK;
}

int hal_sim_flash_setup(const hal_sim_config *cfg, char *err, int errlen)
{
    F.g.block_size = cfg->flash_block_size ? cfg->flash_block_size : HAL_SIM_FLASH_BLOCK_SIZE;
    F.g.block_count = cfg->flash_block_count ? cfg->flash_block_count : HAL_SIM_FLASH_BLOCK_COUNT;
    F.g.prog_size = cfg->flash_prog_size ? cfg->flash_prog_size : HAL_SIM_FLASH_PROG_SIZE;
    if (!is_pow2(F.g.block_size) || !is_pow2(F.g.prog_size) || F.g.prog_size > 256 ||
        F.g.prog_size > F.g.block_size || (uint64_t)F.g.block_size * F.g.block_count > 0x80000000u) {
        snprintf(err, (size_t)errlen, "bad flash geometry: block %u x %u, program unit %u", F.g.block_size,
                 F.g.block_count, F.g.prog_size);
        return WDR_E_INVAL;
    }
    F.size = (size_t)F.g.block_size * F.g.block_count;
    F.bytes = malloc(F.size);
    F.programmed = calloc(F.size / F.g.prog_size, 1);
    if (!F.bytes || !F.programmed) {
        snprintf(err, (size_t)errlen, "no memory for %zu bytes of flash", F.size);
        return WDR_E_NOMEM;
    }
    memset(F.bytes, 0xFF, F.size);
    F.fd = -1;
    F.ops = F.cut_at = F.fail_at = 0;
    F.power_lost = 0;
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

void hal_sim_flash_reboot(void) { F.power_lost = 0; }

/* Count a mutating operation; returns the injected fault for it, or WDR_OK. */
static int count_op(void)
{
    F.ops++;
    if (F.cut_at && F.ops == F.cut_at) {
        F.cut_at = 0;
        F.power_lost = 1;
        return WDR_E_POWER;
    }
    if (F.fail_at && F.ops == F.fail_at) {
        F.fail_at = 0;
        return WDR_E_IO;
    }
    return WDR_OK;
}

/* ---- The HAL functions ------------------------------------------------------------------ */

int hal_flash_geometry_get(hal_flash_geometry *g)
{
    if (!F.bytes)
        return WDR_E_IO;
    *g = F.g;
    return WDR_OK;
}

int hal_flash_read(uint32_t addr, void *buf, uint32_t len)
{
    if (F.power_lost)
        return WDR_E_POWER;
    if (!buf || (uint64_t)addr + len > F.size)
        return WDR_E_INVAL;
    memcpy(buf, F.bytes + addr, len);
    return WDR_OK;
}

static void erase_range(uint32_t addr, uint32_t len)
{
    memset(F.bytes + addr, 0xFF, len);
    memset(F.programmed + addr / F.g.prog_size, 0, len / F.g.prog_size);
    persist(addr, len);
}

int hal_flash_erase(uint32_t block)
{
    if (F.power_lost)
        return WDR_E_POWER;
    if (block >= F.g.block_count)
        return WDR_E_INVAL;
    uint32_t addr = block * F.g.block_size;
    int fault = count_op();
    if (fault == WDR_E_IO)
        return fault;
    /* A cut erase has cleared only the first half of the block. */
    erase_range(addr, fault == WDR_E_POWER ? F.g.block_size / 2 : F.g.block_size);
    return fault;
}

static int check_prog(uint32_t addr, const void *buf, uint32_t len)
{
    if (!buf || addr % F.g.prog_size || len % F.g.prog_size || (uint64_t)addr + len > F.size)
        return WDR_E_INVAL;
    for (uint32_t u = addr / F.g.prog_size; u < (addr + len) / F.g.prog_size; u++)
        if (F.programmed[u])
            return WDR_E_IO; /* programming over programmed bits: refused, never ANDed in */
    for (uint32_t i = 0; i < len; i++)
        if (F.bytes[addr + i] != 0xFF)
            return WDR_E_IO;
    return WDR_OK;
}

int hal_flash_prog(uint32_t addr, const void *buf, uint32_t len)
{
    if (F.power_lost)
        return WDR_E_POWER;
    int rc = check_prog(addr, buf, len);
    if (rc != WDR_OK)
        return rc;
    int fault = count_op();
    if (fault == WDR_E_IO)
        return fault;
    /* A cut program has written its first half; the units it touched count as programmed. */
    uint32_t done = fault == WDR_E_POWER ? len / 2 : len;
    memcpy(F.bytes + addr, buf, done);
    uint32_t units = (done + F.g.prog_size - 1) / F.g.prog_size;
    memset(F.programmed + addr / F.g.prog_size, 1, units);
    persist(addr, done);
    return fault;
}

/* ---- Emulator control -------------------------------------------------------------------- */

void hal_sim_cut_power_at(uint64_t n) { F.cut_at = n ? F.ops + n : 0; }

void hal_sim_fail_flash_at(uint64_t n) { F.fail_at = n ? F.ops + n : 0; }

uint64_t hal_sim_flash_ops(void) { return F.ops; }

int hal_sim_power_lost(void) { return F.power_lost; }

void hal_sim_flash_reset(void)
{
    if (F.bytes)
        erase_range(0, (uint32_t)F.size);
}

const uint8_t *hal_sim_flash_bytes(size_t *size)
{
    *size = F.size;
    return F.bytes;
}
