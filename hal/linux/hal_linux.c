/* Real board on embedded Linux, core: identity, events, time, the sensor control lines
 * (hal_linux_lines.c), ramp playback to the DAC and the column ADC (spidev), and the order of
 * bring-up and shutdown. The board is data (hal_linux_board.h), set before hal_init.
 *
 * Threads stand in for interrupts: they only post events (an eventfd wakes the task loop).
 * Ramp playback from user space has tens of microseconds of jitter: good for bring-up; a
 * product plays the LUT from a timer-driven DMA or an FPGA behind the same hal_ramp_start. */
#include "hal_event_ring.h"
#include "hal_linux_internal.h"
#include <errno.h>
#include <fcntl.h>
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


static struct {
    pthread_mutex_t lock;
    hal_event_ring events; /* posts come from several threads: under lock */
    int wake_fd, timer_fd;
    uint64_t t0_ns;
    int dac_fd, adc_fd;
    int values[LX_MAX_LINES];
    int row_selected, converted;
    uint16_t row[HAL_LINUX_MAX_WIDTH];
    pthread_t ramp_thread;
    int ramp_running;
    atomic_int ramp_abort, ramp_playing;
    const wdr_lut_view *lut;
} L = {.lock = PTHREAD_MUTEX_INITIALIZER, .wake_fd = -1, .timer_fd = -1, .dac_fd = -1, .adc_fd = -1};

/* ---- The board ------------------------------------------------------------------------------ */

static lx_board board;
_Static_assert(sizeof board.name == HAL_BOARD_NAME_MAX, "a board name is hal_board_info's");
static const lx_board *B = &board;

void lx_board_use(const lx_board *b) { board = *b; }
const lx_board *lx_board_get(void) { return B; }

static int gpio_write(void) { return lx_lines_set(L.values); }

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
static int spi_open(const lx_spi_ref *spi)
{
    int fd = open(spi->path, O_RDWR | O_CLOEXEC);
    if (fd < 0) {
        lx_fail("open", spi->path);
        return -1;
    }
    uint32_t hz = spi->speed_hz;
    uint8_t bits = 8, mode = SPI_MODE_0;
    const char *call = ioctl(fd, SPI_IOC_WR_MODE, &mode) < 0                ? "ioctl SPI_IOC_WR_MODE"
                       : ioctl(fd, SPI_IOC_WR_BITS_PER_WORD, &bits) < 0   ? "ioctl SPI_IOC_WR_BITS_PER_WORD"
                       : ioctl(fd, SPI_IOC_WR_MAX_SPEED_HZ, &hz) < 0      ? "ioctl SPI_IOC_WR_MAX_SPEED_HZ"
                                                                         : NULL;
    if (call) {
        lx_fail(call, spi->path);
        close(fd);
        return -1;
    }
    return fd;
}

static void close_fd(int *fd)
{
    if (*fd >= 0)
        close(*fd);
    *fd = -1;
}

int lx_spi_fd(int adc) { return adc ? L.adc_fd : L.dac_fd; }

/* The converters, the control lines (all low) and the table flash: everything but USB. */
int lx_devices_open(void)
{
    L.dac_fd = spi_open(&B->dac);
    if (L.dac_fd < 0)
        return WDR_E_IO;
    L.adc_fd = spi_open(&B->adc);
    if (L.adc_fd < 0)
        return WDR_E_IO;
    memset(L.values, 0, sizeof L.values);
    if (lx_lines_open(B) != WDR_OK)
        return WDR_E_IO;
    if (gpio_write() != WDR_OK)
        return lx_fail("gpio line set", lx_lines_chip());
    return lx_flash_init();
}

void lx_devices_close(void)
{
    lx_flash_close();
    lx_lines_close();
    close_fd(&L.dac_fd);
    close_fd(&L.adc_fd);
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
    if (lx_devices_open() != WDR_OK || lx_usb_init() != WDR_OK)
        return WDR_E_IO;
    return WDR_OK;
}

void lx_wake_from_signal(void)
{
    uint64_t one = 1;
    if (L.wake_fd >= 0 && write(L.wake_fd, &one, sizeof one) < 0) {
        /* saturated: the loop is awake anyway */
    }
}

/* The ramp first (no DAC word after this), then the gadget's endpoints (the kernel unbinds the
 * UDC when ep0 closes), then the lines back low and the devices closed. The flash needs nothing:
 * each HAL flash call completes before it returns, so between two firmware tasks it is whole. */
void lx_shutdown(void)
{
    hal_ramp_stop();
    lx_usb_close();
    memset(L.values, 0, sizeof L.values);
    if (L.dac_fd >= 0)
        gpio_write();
    lx_devices_close();
    close_fd(&L.timer_fd);
    close_fd(&L.wake_fd);
}

int hal_board_info_get(hal_board_info *out)
{
    memset(out, 0, sizeof *out);
    out->sensor_id = B->sensor_id;
    out->width = B->width;
    out->height = B->height;
    out->adc_bits = B->adc_bits;
    out->dac_bits = B->dac_bits;
    out->row_time_ns = B->row_time_ns;
    memcpy(out->name, B->name, sizeof out->name - 1); /* both HAL_BOARD_NAME_MAX, NUL-padded */
    return WDR_OK;
}

/* ---- Control lines and ADC ------------------------------------------------------------------- */

int hal_pixel_reset(bool asserted)
{
    L.values[LX_LINE_RESET] = asserted;
    return gpio_write();
}

int hal_row_select(uint16_t row)
{
    if (row >= B->height)
        return WDR_E_INVAL;
    for (unsigned b = 0; b + 3u < B->n_lines; b++)
        L.values[LX_LINE_ROW_ADDR0 + b] = (row >> b) & 1u;
    L.values[LX_LINE_ROW_SELECT] = 1;
    L.row_selected = row;
    return gpio_write();
}

void hal_row_deselect(void)
{
    L.values[LX_LINE_ROW_SELECT] = 0;
    L.row_selected = -1;
    gpio_write();
}

static int adc_shift_out(void)
{
    uint8_t rx[HAL_LINUX_MAX_WIDTH * 2u];
    struct spi_ioc_transfer t = {.rx_buf = (uintptr_t)rx, .len = B->width * 2u};
    if (ioctl(L.adc_fd, SPI_IOC_MESSAGE(1), &t) < 0)
        return WDR_E_IO;
    for (unsigned i = 0; i < B->width; i++)
        L.row[i] = (uint16_t)(((rx[2 * i] << 8) | rx[2 * i + 1]) & ((1u << B->adc_bits) - 1u));
    return WDR_OK;
}

int hal_adc_convert(void)
{
    if (atomic_load(&L.ramp_playing))
        return WDR_E_BUSY;
    if (L.row_selected < 0)
        return WDR_E_INVAL;
    L.values[LX_LINE_ADC_CONVERT] = 1;
    if (gpio_write() != WDR_OK)
        return WDR_E_IO;
    hal_delay_ns(B->adc_convert_ns);
    L.values[LX_LINE_ADC_CONVERT] = 0;
    if (gpio_write() != WDR_OK)
        return WDR_E_IO;
    int rc = adc_shift_out();
    L.converted = rc == WDR_OK;
    return rc;
}

int hal_adc_read_row(uint16_t *codes, size_t n)
{
    if (n != B->width || !L.converted)
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
    double ns_per_tick = (lut->h.tick_ps + lut->tick_frac_q16 / 65536.0) / 1000.0;
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
    if (lut->h.dac_bits != B->dac_bits)
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
