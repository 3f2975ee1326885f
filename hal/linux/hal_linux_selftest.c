/* wdr-board --self-test: every control line driven once and read back, the DAC written once,
 * the column ADC converted and read once, on the board's own devices (no USB). The first one
 * that does not answer as expected is named with its device, line and errno; a miswired or
 * unbound line shows as a pin that does not follow what is driven. */
#include "hal_linux_internal.h"
#include <errno.h>
#include <linux/spi/spidev.h>
#include <string.h>
#include <sys/ioctl.h>
#include <time.h>
#include <unistd.h>

static int values[LX_MAX_LINES];

static const char *role(unsigned i)
{
    static char buf[32];
    return lx_line_role(i, buf, sizeof buf);
}

/* Drive `values`, read back, and compare every line; the first differing line is reported. */
static int drive_and_check(FILE *out, const lx_board *b, unsigned tested)
{
    int got[LX_MAX_LINES];
    if (lx_lines_set(values) != WDR_OK || lx_lines_get(got) != WDR_OK) {
        fprintf(out, "FAIL line %s (%s offset %u): %s: %s (errno %d)\n", role(tested), lx_lines_chip(),
                lx_lines_offset(tested), "gpio set/get", strerror(errno), errno);
        return -1;
    }
    for (unsigned i = 0; i < b->n_lines; i++)
        if (got[i] != values[i]) {
            fprintf(out,
                    "FAIL line %s (%s offset %u): driven %d, reads %d while testing %s (errno 0: the pin does not "
                    "follow; unbound, shorted or miswired?)\n",
                    role(i), lx_lines_chip(), lx_lines_offset(i), values[i], got[i], role(tested));
            return -1;
        }
    return 0;
}

/* Each line high then low, the others low; the convert line with row select high, as the
 * sensor expects. */
static int test_lines(FILE *out, const lx_board *b)
{
    memset(values, 0, sizeof values);
    if (drive_and_check(out, b, 0) != 0)
        return -1;
    for (unsigned i = 0; i < b->n_lines; i++) {
        values[i] = 1;
        if (i == LX_LINE_ADC_CONVERT)
            values[LX_LINE_ROW_SELECT] = 1;
        if (drive_and_check(out, b, i) != 0)
            return -1;
        memset(values, 0, sizeof values);
        if (drive_and_check(out, b, i) != 0)
            return -1;
        fprintf(out, "ok   line %-15s %s offset %u: drove 1 and 0, read back 1 and 0\n", role(i), lx_lines_chip(),
                lx_lines_offset(i));
    }
    return 0;
}

static void pulse(unsigned line, uint32_t ns)
{
    values[line] = 1;
    lx_lines_set(values);
    struct timespec ts = {0, (long)ns};
    nanosleep(&ts, NULL);
    values[line] = 0;
    lx_lines_set(values);
}

/* One DAC word after a reset pulse, then a convert of row 0 and one ADC row read: every word
 * must fit the converter's bits (a disconnected MISO reads all ones). */
static int test_converters(FILE *out, const lx_board *b)
{
    uint16_t code = (uint16_t)(1u << (b->dac_bits - 1u));
    uint8_t w[2] = {(uint8_t)(code >> 8), (uint8_t)code};
    memset(values, 0, sizeof values);
    pulse(LX_LINE_RESET, 1000);
    if (write(lx_spi_fd(0), w, 2) != 2) {
        fprintf(out, "FAIL spi dac %s: write of one word: %s (errno %d)\n", b->dac.path, strerror(errno), errno);
        return -1;
    }
    fprintf(out, "ok   spi dac %s: one word (code %u) at %u Hz\n", b->dac.path, code, b->dac.speed_hz);
    values[LX_LINE_ROW_SELECT] = 1;
    pulse(LX_LINE_ADC_CONVERT, b->adc_convert_ns);
    uint8_t rx[HAL_LINUX_MAX_WIDTH * 2u];
    struct spi_ioc_transfer t = {.rx_buf = (uintptr_t)rx, .len = b->width * 2u, .speed_hz = b->adc.speed_hz};
    int rc = ioctl(lx_spi_fd(1), SPI_IOC_MESSAGE(1), &t);
    int err = errno;
    values[LX_LINE_ROW_SELECT] = 0;
    lx_lines_set(values);
    if (rc < 0) {
        fprintf(out, "FAIL spi adc %s: read of %u words: %s (errno %d)\n", b->adc.path, b->width, strerror(err), err);
        return -1;
    }
    unsigned max = (1u << b->adc_bits) - 1u, same = 0;
    for (unsigned c = 0; c < b->width; c++) {
        unsigned v = (unsigned)(rx[2 * c] << 8 | rx[2 * c + 1]);
        if (v > max) {
            fprintf(out, "FAIL spi adc %s: column %u reads 0x%04x, above %u bits (errno 0: MISO not connected?)\n",
                    b->adc.path, c, v, b->adc_bits);
            return -1;
        }
        same += v == code;
    }
    fprintf(out, "ok   spi adc %s: %u words within %u bits; %u of them equal the DAC code (a loop-back model: all)\n",
            b->adc.path, b->width, b->adc_bits, same);
    return 0;
}

int lx_self_test(FILE *out)
{
    const lx_board *b = lx_board_get();
    if (lx_devices_open() != WDR_OK) {
        fprintf(out, "FAIL bring-up: %s (errno %d)\n", lx_bringup_error(), errno);
        lx_devices_close();
        return 1;
    }
    char label[HAL_LINUX_PATH_MAX] = "?";
    lx_gpio_chip_label(label, sizeof label);
    fprintf(out, "board %s: chip %s (label %s, %u lines, %s), flash %s\n", b->name, lx_lines_chip(), label,
            lx_gpio_chip_lines(), lx_gpio_library(), lx_flash_device());
    int rc = test_lines(out, b) == 0 && test_converters(out, b) == 0 ? 0 : 1;
    memset(values, 0, sizeof values);
    lx_lines_set(values);
    lx_devices_close();
    fprintf(out, "self-test: %s (%u lines, 2 SPI devices)\n", rc ? "FAIL" : "PASS", b->n_lines);
    return rc;
}
