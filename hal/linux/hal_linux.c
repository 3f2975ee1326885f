/* Real board on embedded Linux, core: identity, events, time, the sensor control lines
 * (libgpiod 1.x, Debian 12's 1.6), ramp playback to the DAC and the column ADC (spidev).
 *
 * Threads stand in for interrupts: they only post events (an eventfd wakes the task loop).
 * Ramp playback from user space has tens of microseconds of jitter: good for bring-up; a
 * product plays the LUT from a timer-driven DMA or an FPGA behind the same hal_ramp_start. */
#include "hal_event_ring.h"
#include "hal_linux_internal.h"
#include <errno.h>
#include <fcntl.h>
#include <gpiod.h>
#include <linux/spi/spidev.h>
#include <poll.h>
#include <stdio.h>
#include <pthread.h>
#include <stdatomic.h>
#include <string.h>
#include <sys/eventfd.h>
#include <sys/ioctl.h>
#include <sys/timerfd.h>
#include <time.h>
#include <unistd.h>

#define N_LINES (3u + HAL_LINUX_ROW_ADDR_BITS)
enum { LINE_RESET, LINE_ROW_SELECT, LINE_ADC_CONVERT, LINE_ROW_ADDR0 };

static struct {
    pthread_mutex_t lock;
    hal_event_ring events; /* posts come from several threads: under lock */
    int wake_fd, timer_fd;
    uint64_t t0_ns;
    int dac_fd, adc_fd;
    int values[N_LINES];
    int row_selected, converted;
    uint16_t row[HAL_LINUX_WIDTH];
    pthread_t ramp_thread;
    int ramp_running;
    atomic_int ramp_abort, ramp_playing;
    const wdr_lut_view *lut;
} L = {.lock = PTHREAD_MUTEX_INITIALIZER, .wake_fd = -1, .timer_fd = -1, .dac_fd = -1, .adc_fd = -1};

/* ---- GPIO (libgpiod 1.x: the build stops on 2.x, see CMakeLists.txt) ----------------------- */

static struct gpiod_chip *gpio_chip;
static struct gpiod_line_bulk gpio_bulk;

static unsigned line_offsets(unsigned i)
{
    static const unsigned fixed[3] = {HAL_LINUX_LINE_RESET, HAL_LINUX_LINE_ROW_SELECT, HAL_LINUX_LINE_ADC_CONVERT};
    return i < 3 ? fixed[i] : HAL_LINUX_LINE_ROW_ADDR0 + (i - 3);
}

static int gpio_open(void)
{
    unsigned offsets[N_LINES];
    int zeros[N_LINES] = {0};
    for (unsigned i = 0; i < N_LINES; i++)
        offsets[i] = line_offsets(i);
    gpio_chip = gpiod_chip_open(HAL_LINUX_GPIOCHIP);
    if (!gpio_chip)
        return lx_fail("gpiod_chip_open", HAL_LINUX_GPIOCHIP);
    if (gpiod_chip_get_lines(gpio_chip, offsets, N_LINES, &gpio_bulk) != 0)
        return lx_fail("gpiod_chip_get_lines (reset, row select, convert, row address)", HAL_LINUX_GPIOCHIP);
    if (gpiod_line_request_bulk_output(&gpio_bulk, "wdrcam", zeros) != 0)
        return lx_fail("gpiod_line_request_bulk_output", HAL_LINUX_GPIOCHIP);
    return WDR_OK;
}

static int gpio_write(void) { return gpiod_line_set_value_bulk(&gpio_bulk, L.values) == 0 ? WDR_OK : WDR_E_IO; }

/* ---- Bring-up errors ----------------------------------------------------------------------- */

static char bringup_error[320];

int lx_fail(const char *call, const char *what)
{
    int err = errno;
    snprintf(bringup_error, sizeof bringup_error, "%s %s: %s", call, what, err ? strerror(err) : "failed");
    errno = err;
    return WDR_E_IO;
}

const char *lx_bringup_error(void) { return bringup_error; }

/* ---- Events and time ---------------------------------------------------------------------- */

void lx_post(uint8_t type, uint32_t arg)
{
    pthread_mutex_lock(&L.lock);
    hal_event_ring_post(&L.events, type, arg);
    pthread_mutex_unlock(&L.lock);
    uint64_t one = 1;
    if (write(L.wake_fd, &one, sizeof one) < 0) {
        /* the counter is saturated: the loop is awake anyway */
    }
}

static uint64_t mono_ns(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (uint64_t)ts.tv_sec * 1000000000u + (uint64_t)ts.tv_nsec;
}

/* A fired timerfd becomes a HAL_EV_TIMER. */
static void take_timer(void)
{
    uint64_t n;
    if (read(L.timer_fd, &n, sizeof n) == (ssize_t)sizeof n && n > 0)
        lx_post(HAL_EV_TIMER, 0);
}

int hal_event_poll(hal_event *ev)
{
    struct pollfd p = {.fd = L.timer_fd, .events = POLLIN};
    if (poll(&p, 1, 0) > 0)
        take_timer();
    pthread_mutex_lock(&L.lock);
    int got = hal_event_ring_take(&L.events, ev);
    pthread_mutex_unlock(&L.lock);
    return got;
}

void hal_wait_for_event(void)
{
    struct pollfd p[2] = {{.fd = L.wake_fd, .events = POLLIN}, {.fd = L.timer_fd, .events = POLLIN}};
    if (poll(p, 2, -1) <= 0)
        return;
    uint64_t n;
    if ((p[0].revents & POLLIN) && read(L.wake_fd, &n, sizeof n) < 0)
        return;
    if (p[1].revents & POLLIN)
        take_timer();
}

uint64_t hal_time_ns(void) { return mono_ns() - L.t0_ns; }

void hal_delay_ns(uint32_t ns)
{
    struct timespec ts = {.tv_sec = ns / 1000000000u, .tv_nsec = ns % 1000000000u};
    while (clock_nanosleep(CLOCK_MONOTONIC, 0, &ts, &ts) == EINTR) {
    }
}

void hal_timer_arm(uint64_t deadline_ns)
{
    uint64_t at = L.t0_ns + deadline_ns;
    struct itimerspec its = {.it_value = {.tv_sec = (time_t)(at / 1000000000u), .tv_nsec = (long)(at % 1000000000u)}};
    if (its.it_value.tv_sec == 0 && its.it_value.tv_nsec == 0)
        its.it_value.tv_nsec = 1; /* zero would disarm */
    timerfd_settime(L.timer_fd, TFD_TIMER_ABSTIME, &its, NULL);
}

/* ---- Init and identity --------------------------------------------------------------------- */

/* A spidev node set to mode 0, 8-bit words and the board's clock; -1 with the error recorded. */
static int spi_open(const char *path)
{
    int fd = open(path, O_RDWR | O_CLOEXEC);
    if (fd < 0) {
        lx_fail("open", path);
        return -1;
    }
    uint32_t hz = HAL_LINUX_SPI_HZ;
    uint8_t bits = 8, mode = SPI_MODE_0;
    const char *call = ioctl(fd, SPI_IOC_WR_MODE, &mode) < 0                ? "ioctl SPI_IOC_WR_MODE"
                       : ioctl(fd, SPI_IOC_WR_BITS_PER_WORD, &bits) < 0   ? "ioctl SPI_IOC_WR_BITS_PER_WORD"
                       : ioctl(fd, SPI_IOC_WR_MAX_SPEED_HZ, &hz) < 0      ? "ioctl SPI_IOC_WR_MAX_SPEED_HZ"
                                                                         : NULL;
    if (call) {
        lx_fail(call, path);
        close(fd);
        return -1;
    }
    return fd;
}

int hal_init(void)
{
    L.t0_ns = mono_ns();
    L.row_selected = -1;
    L.wake_fd = eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK);
    if (L.wake_fd < 0)
        return lx_fail("eventfd", "(event queue)");
    L.timer_fd = timerfd_create(CLOCK_MONOTONIC, TFD_CLOEXEC | TFD_NONBLOCK);
    if (L.timer_fd < 0)
        return lx_fail("timerfd_create", "CLOCK_MONOTONIC");
    L.dac_fd = spi_open(HAL_LINUX_SPI_DAC);
    if (L.dac_fd < 0)
        return WDR_E_IO;
    L.adc_fd = spi_open(HAL_LINUX_SPI_ADC);
    if (L.adc_fd < 0)
        return WDR_E_IO;
    if (gpio_open() != WDR_OK)
        return WDR_E_IO;
    if (gpio_write() != WDR_OK)
        return lx_fail("gpiod_line_set_value_bulk", HAL_LINUX_GPIOCHIP);
    if (lx_flash_init() != WDR_OK || lx_usb_init() != WDR_OK)
        return WDR_E_IO;
    return WDR_OK;
}

int hal_board_info_get(hal_board_info *out)
{
    memset(out, 0, sizeof *out);
    out->sensor_id = HAL_LINUX_SENSOR_ID;
    out->width = HAL_LINUX_WIDTH;
    out->height = HAL_LINUX_HEIGHT;
    out->adc_bits = HAL_LINUX_ADC_BITS;
    out->dac_bits = HAL_LINUX_DAC_BITS;
    out->row_time_ns = HAL_LINUX_ROW_TIME_NS;
    strncpy(out->name, HAL_LINUX_BOARD_NAME, sizeof out->name - 1);
    return WDR_OK;
}

/* ---- Control lines and ADC ------------------------------------------------------------------- */

int hal_pixel_reset(bool asserted)
{
    L.values[LINE_RESET] = asserted;
    return gpio_write();
}

int hal_row_select(uint16_t row)
{
    if (row >= HAL_LINUX_HEIGHT)
        return WDR_E_INVAL;
    for (unsigned b = 0; b < HAL_LINUX_ROW_ADDR_BITS; b++)
        L.values[LINE_ROW_ADDR0 + b] = (row >> b) & 1u;
    L.values[LINE_ROW_SELECT] = 1;
    L.row_selected = row;
    return gpio_write();
}

void hal_row_deselect(void)
{
    L.values[LINE_ROW_SELECT] = 0;
    L.row_selected = -1;
    gpio_write();
}

static int adc_shift_out(void)
{
    uint8_t rx[HAL_LINUX_WIDTH * 2u];
    struct spi_ioc_transfer t = {.rx_buf = (uintptr_t)rx, .len = sizeof rx};
    if (ioctl(L.adc_fd, SPI_IOC_MESSAGE(1), &t) < 0)
        return WDR_E_IO;
    for (unsigned i = 0; i < HAL_LINUX_WIDTH; i++)
        L.row[i] = (uint16_t)(((rx[2 * i] << 8) | rx[2 * i + 1]) & ((1u << HAL_LINUX_ADC_BITS) - 1u));
    return WDR_OK;
}

int hal_adc_convert(void)
{
    if (atomic_load(&L.ramp_playing))
        return WDR_E_BUSY;
    if (L.row_selected < 0)
        return WDR_E_INVAL;
    L.values[LINE_ADC_CONVERT] = 1;
    if (gpio_write() != WDR_OK)
        return WDR_E_IO;
    hal_delay_ns(HAL_LINUX_ADC_CONVERT_NS);
    L.values[LINE_ADC_CONVERT] = 0;
    if (gpio_write() != WDR_OK)
        return WDR_E_IO;
    int rc = adc_shift_out();
    L.converted = rc == WDR_OK;
    return rc;
}

int hal_adc_read_row(uint16_t *codes, size_t n)
{
    if (n != HAL_LINUX_WIDTH || !L.converted)
        return WDR_E_INVAL;
    memcpy(codes, L.row, n * sizeof *codes);
    return WDR_OK;
}

/* ---- Ramp playback ------------------------------------------------------------------------------ */

static void sleep_until(uint64_t abs_ns)
{
    struct timespec ts = {.tv_sec = (time_t)(abs_ns / 1000000000u), .tv_nsec = (long)(abs_ns % 1000000000u)};
    while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, NULL) == EINTR) {
    }
}

static void dac_write(uint16_t code)
{
    uint8_t w[2] = {(uint8_t)(code >> 8), (uint8_t)code};
    if (write(L.dac_fd, w, 2) != 2) {
        /* a lost step shows up as a wrong frame, not a hang; nothing to report from here */
    }
}

static void *ramp_main(void *arg)
{
    const wdr_lut_view *lut = arg;
    uint64_t t0 = mono_ns();
    double ns_per_tick = lut->h.tick_ps / 1000.0;
    for (uint32_t i = 0; i < lut->h.entry_count && !atomic_load(&L.ramp_abort); i++) {
        uint32_t t;
        uint16_t code;
        wdr_lut_entry(lut, i, &t, &code);
        sleep_until(t0 + (uint64_t)(t * ns_per_tick));
        dac_write(code);
    }
    sleep_until(t0 + (uint64_t)(lut->h.t_integration_ticks * ns_per_tick));
    atomic_store(&L.ramp_playing, 0);
    if (!atomic_load(&L.ramp_abort))
        lx_post(HAL_EV_RAMP_DONE, 0);
    return NULL;
}

static void ramp_join(void)
{
    if (L.ramp_running)
        pthread_join(L.ramp_thread, NULL);
    L.ramp_running = 0;
}

int hal_ramp_start(const wdr_lut_view *lut)
{
    if (!lut || !lut->entries || lut->h.entry_count == 0)
        return WDR_E_INVAL;
    if (atomic_load(&L.ramp_playing))
        return WDR_E_BUSY;
    if (lut->h.dac_bits != HAL_LINUX_DAC_BITS)
        return WDR_E_GEOMETRY;
    ramp_join();
    atomic_store(&L.ramp_abort, 0);
    atomic_store(&L.ramp_playing, 1);
    L.converted = 0;
    if (pthread_create(&L.ramp_thread, NULL, ramp_main, (void *)lut) != 0) {
        atomic_store(&L.ramp_playing, 0);
        return WDR_E_IO;
    }
    L.ramp_running = 1;
    return WDR_OK;
}

void hal_ramp_stop(void)
{
    atomic_store(&L.ramp_abort, 1);
    ramp_join();
    atomic_store(&L.ramp_playing, 0);
}

int hal_set_illuminant(double amps)
{
    (void)amps;
    return WDR_E_UNSUPPORTED;
}

int hal_restore_scene(void) { return WDR_E_UNSUPPORTED; }
