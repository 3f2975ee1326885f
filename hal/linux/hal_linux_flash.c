/* Real board on embedded Linux, flash: the table partition as an MTD character device
 * (MEMGETINFO, MEMERASE, pread/pwrite). The HAL contract is stricter than NOR hardware,
 * which would silently AND new bits into old ones: programming checks that the range is erased. */
#include "hal_linux_internal.h"
#include <errno.h>
#include <fcntl.h>
#include <mtd/mtd-user.h>
#include <stdio.h>
#include <string.h>
#include <sys/ioctl.h>
#include <unistd.h>

#define MIN_PROG_SIZE 16u /* NOR reports 1; the firmware pads its records to this anyway */

static struct {
    int fd;
    hal_flash_geometry g;
} M = {.fd = -1};

static char mtd_path[HAL_LINUX_PATH_MAX + 16];

const char *lx_flash_device(void) { return mtd_path; }

/* The device of the MTD partition named `name` in /proc/mtd ("mtd2: 00100000 00010000 \"name\"").
 * -1 with errno ENOENT when no partition has that name. */
static int find_partition(const char *name)
{
    FILE *f = fopen("/proc/mtd", "r");
    if (!f)
        return -1;
    char line[256];
    int found = 0;
    while (!found && fgets(line, sizeof line, f)) {
        unsigned index;
        char quoted[200];
        if (sscanf(line, "mtd%u: %*x %*x \"%199[^\"]\"", &index, quoted) == 2 && !strcmp(quoted, name)) {
            snprintf(mtd_path, sizeof mtd_path, "/dev/mtd%u", index);
            found = 1;
        }
    }
    fclose(f);
    errno = ENOENT;
    return found ? 0 : -1;
}

int lx_flash_init(void)
{
    struct mtd_info_user info;
    const char *spec = lx_board_get()->mtd;
    if (spec[0] == '/') {
        snprintf(mtd_path, sizeof mtd_path, "%s", spec);
    } else if (find_partition(spec) != 0) {
        char what[HAL_LINUX_PATH_MAX + 64];
        snprintf(what, sizeof what, "'%s' (no such partition in /proc/mtd)", spec);
        return lx_fail("MTD partition", what);
    }
    M.fd = open(mtd_path, O_RDWR | O_CLOEXEC);
    if (M.fd < 0)
        return lx_fail("open", mtd_path);
    if (ioctl(M.fd, MEMGETINFO, &info) < 0)
        return lx_fail("ioctl MEMGETINFO", mtd_path);
    errno = EINVAL;
    if (info.erasesize == 0)
        return lx_fail("ioctl MEMGETINFO (erase size 0)", mtd_path);
    M.g.block_size = info.erasesize;
    M.g.block_count = info.size / info.erasesize;
    M.g.prog_size = info.writesize < MIN_PROG_SIZE ? MIN_PROG_SIZE : info.writesize;
    if (M.g.prog_size > 256) {
        lx_fail("ioctl MEMGETINFO (write size above 256 bytes: NAND is not supported)", mtd_path);
        return WDR_E_UNSUPPORTED;
    }
    return WDR_OK;
}

/* Every program and erase is synchronous (pwrite, MEMERASE), so closing loses nothing. */
void lx_flash_close(void)
{
    if (M.fd >= 0)
        close(M.fd);
    M.fd = -1;
}

int hal_flash_geometry_get(hal_flash_geometry *g)
{
    if (M.fd < 0)
        return WDR_E_IO;
    *g = M.g;
    return WDR_OK;
}

static int in_range(uint32_t addr, uint32_t len)
{
    return (uint64_t)addr + len <= (uint64_t)M.g.block_size * M.g.block_count;
}

int hal_flash_read(uint32_t addr, void *buf, uint32_t len)
{
    if (!buf || !in_range(addr, len))
        return WDR_E_INVAL;
    return pread(M.fd, buf, len, addr) == (ssize_t)len ? WDR_OK : WDR_E_IO;
}

int hal_flash_erase(uint32_t block)
{
    if (block >= M.g.block_count)
        return WDR_E_INVAL;
    struct erase_info_user e = {.start = block * M.g.block_size, .length = M.g.block_size};
    return ioctl(M.fd, MEMERASE, &e) == 0 ? WDR_OK : WDR_E_IO;
}

static int is_erased(uint32_t addr, uint32_t len)
{
    uint8_t buf[256];
    for (uint32_t done = 0; done < len; done += sizeof buf) {
        uint32_t n = len - done < sizeof buf ? len - done : (uint32_t)sizeof buf;
        if (pread(M.fd, buf, n, addr + done) != (ssize_t)n)
            return 0;
        for (uint32_t i = 0; i < n; i++)
            if (buf[i] != 0xFF)
                return 0;
    }
    return 1;
}

int hal_flash_prog(uint32_t addr, const void *buf, uint32_t len)
{
    if (!buf || addr % M.g.prog_size || len % M.g.prog_size || !in_range(addr, len))
        return WDR_E_INVAL;
    if (!is_erased(addr, len))
        return WDR_E_IO;
    return pwrite(M.fd, buf, len, addr) == (ssize_t)len ? WDR_OK : WDR_E_IO;
}
