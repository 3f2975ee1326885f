/* The board contract: everything the firmware may ask of the hardware, and nothing more.
 * One backend .c per board family implements every function here (hal/sim, hal/linux,
 * hal/template); CMake picks one at link time. The firmware never learns which.
 *
 * Rules every backend keeps:
 * - Errors are negative enum wdr_err codes; each prototype lists the ones it may return.
 * - Interrupt-like happenings (bytes arrived, transfer done, ramp done, timer) only post a
 *   hal_event to a fixed-size queue; the firmware's task loop takes them with hal_event_poll.
 * - Time is monotonic nanoseconds. In the simulator it is virtual: waits advance it, and
 *   hal_wait_for_event jumps it to the next scheduled happening.
 * - Flash is NOR-like: erase a block to 0xFF, then program aligned units of prog_size bytes
 *   that were erased; programming a unit twice without an erase is refused. */
#ifndef WDR_HAL_H
#define WDR_HAL_H
#include "wdr_err.h"
#include "wdr_lut.h"
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

/* ---- Board identity ------------------------------------------------------------------- */

#define HAL_BOARD_NAME_MAX 32
#define HAL_CAP_ILLUMINANT 0x1u /* hal_set_illuminant works (simulated boards only) */

typedef struct hal_board_info {
    uint32_t sensor_id;          /* die/variant id; tables carry it and must match */
    uint16_t width, height;      /* pixel array */
    uint8_t adc_bits, dac_bits;  /* column ADC and ramp DAC resolution */
    uint32_t row_time_ns;        /* minimum time between two row reads */
    uint32_t caps;               /* HAL_CAP_* bits */
    char name[HAL_BOARD_NAME_MAX]; /* NUL-terminated board name */
} hal_board_info;

/* Bring up clocks and peripherals; the program's main calls it once before the firmware.
 * @retval WDR_OK  @retval WDR_E_IO  a peripheral did not answer */
int hal_init(void);

/* Describe the board and sensor. @retval WDR_OK  @retval WDR_E_IO */
int hal_board_info_get(hal_board_info *out);

/* ---- Events: posted by interrupt-like sources, taken by the task loop ----------------- */

enum hal_event_type {
    HAL_EV_USB_RX = 1,      /* bulk OUT has bytes: read them with hal_usb_read */
    HAL_EV_USB_TX_DONE = 2, /* the transfer of hal_usb_write finished; its buffer is free */
    HAL_EV_RAMP_DONE = 3,   /* ramp playback reached t_integration; pixels hold their values */
    HAL_EV_TIMER = 4,       /* the deadline of hal_timer_arm passed */
    HAL_EV_USB_RESET = 5    /* host (dis)connected or reset the bus: drop partial packets */
};

typedef struct hal_event {
    uint8_t type;  /* enum hal_event_type */
    uint32_t arg;  /* type-specific; 0 unless documented */
} hal_event;

/* Take the oldest queued event without blocking. @retval 1 got one  @retval 0 queue empty */
int hal_event_poll(hal_event *ev);

/* Sleep until an event is queued (WFI; the simulator advances virtual time instead). */
void hal_wait_for_event(void);

/* ---- Time ----------------------------------------------------------------------------- */

/* Monotonic time since hal_init, in nanoseconds. */
uint64_t hal_time_ns(void);

/* Wait ns nanoseconds; only for short settling pulses (at most ~100 us). */
void hal_delay_ns(uint32_t ns);

/* Post one HAL_EV_TIMER when hal_time_ns() >= deadline_ns (replaces an armed deadline). */
void hal_timer_arm(uint64_t deadline_ns);

/* ---- Sensor control lines --------------------------------------------------------------- */

/* Drive the global pixel reset line (M1 gates). @retval WDR_OK  @retval WDR_E_IO */
int hal_pixel_reset(bool asserted);

/* Put a row address on the bus and assert row select. @retval WDR_OK  @retval WDR_E_INVAL row >= height */
int hal_row_select(uint16_t row);

/* Release row select. */
void hal_row_deselect(void);

/* Pulse ADC convert: every column samples the selected row now.
 * @retval WDR_OK  @retval WDR_E_INVAL no row selected  @retval WDR_E_BUSY ramp still playing */
int hal_adc_convert(void);

/* Copy the codes of the last conversion into codes[0..n-1] (n is the width).
 * @retval WDR_OK  @retval WDR_E_INVAL n != width or no conversion done  @retval WDR_E_IO */
int hal_adc_read_row(uint16_t *codes, size_t n);

/* ---- Ramp DAC: DMA-like playback of a parsed LUT --------------------------------------- */

/* Release of reset is t = 0: play lut (entry i's code from its time stamp on, holding the last
 * code until h.t_integration_ticks), then post HAL_EV_RAMP_DONE. lut and its entries must stay
 * untouched until then. @retval WDR_OK  @retval WDR_E_BUSY already playing
 * @retval WDR_E_GEOMETRY dac_bits differs from the board's DAC  @retval WDR_E_INVAL bad view */
int hal_ramp_start(const wdr_lut_view *lut);

/* Abort playback; no HAL_EV_RAMP_DONE follows. */
void hal_ramp_stop(void);

/* ---- Flash ------------------------------------------------------------------------------ */

typedef struct hal_flash_geometry {
    uint32_t block_size;   /* erase unit, bytes (power of two) */
    uint32_t block_count;
    uint32_t prog_size;    /* program unit and alignment, bytes (power of two, <= 256) */
} hal_flash_geometry;

/* Geometry of the table flash. @retval WDR_OK  @retval WDR_E_IO */
int hal_flash_geometry_get(hal_flash_geometry *g);

/* Read len bytes at addr. @retval WDR_OK  @retval WDR_E_INVAL out of range
 * @retval WDR_E_IO  @retval WDR_E_POWER power lost (simulator fault injection) */
int hal_flash_read(uint32_t addr, void *buf, uint32_t len);

/* Erase one block to 0xFF. @retval WDR_OK  @retval WDR_E_INVAL block >= block_count
 * @retval WDR_E_IO  @retval WDR_E_POWER */
int hal_flash_erase(uint32_t block);

/* Program len bytes at addr; addr and len are multiples of prog_size and the bytes are erased.
 * @retval WDR_OK  @retval WDR_E_INVAL misaligned or out of range
 * @retval WDR_E_IO  not erased, or the device failed  @retval WDR_E_POWER */
int hal_flash_prog(uint32_t addr, const void *buf, uint32_t len);

/* ---- USB bulk endpoints (non-blocking) --------------------------------------------------- */

/* Largest len hal_usb_write accepts. */
size_t hal_usb_max_transfer(void);

/* Take up to cap received bytes from bulk OUT. @retval >=0 bytes taken (0: none)
 * @retval WDR_E_IO  link gone */
int hal_usb_read(uint8_t *buf, size_t cap);

/* Start a bulk IN transfer of len bytes; buf stays untouched until HAL_EV_USB_TX_DONE.
 * @retval WDR_OK  @retval WDR_E_BUSY a transfer is in flight  @retval WDR_E_TOO_LARGE
 * @retval WDR_E_IO  no host connected */
int hal_usb_write(const uint8_t *buf, size_t len);

/* ---- Firmware images, boot record, reset, watchdog (SPEC.md, "Image flash and boot") -------- */

/* Geometry of the image flash: the floor log and the two image slots the bootloader reads,
 * kept to the same NOR rules as the table flash, and separate from it.
 * @retval WDR_OK  @retval WDR_E_UNSUPPORTED this board has no bootloader (hal/template, linux) */
int hal_image_flash_geometry_get(hal_flash_geometry *g);

/* As hal_flash_read/erase/prog, on the image flash.
 * @retval WDR_OK  @retval WDR_E_INVAL  @retval WDR_E_IO  @retval WDR_E_POWER  @retval WDR_E_UNSUPPORTED */
int hal_image_flash_read(uint32_t addr, void *buf, uint32_t len);
int hal_image_flash_erase(uint32_t block);
int hal_image_flash_prog(uint32_t addr, const void *buf, uint32_t len);

/* What the bootloader passed to this boot (slot, test boot, last reset's cause, header).
 * @retval WDR_OK  @retval WDR_E_UNSUPPORTED not started by a bootloader (no record, or a bad CRC) */
struct wdr_boot_record;
int hal_boot_record_get(struct wdr_boot_record *out);

/* Reset the board with this cause (enum wdr_reset_cause), kept for the next boot's record.
 * Real boards never return; the simulated board returns and reboots when the firmware's task
 * function returns. */
void hal_reset(uint8_t cause);

/* Restart the watchdog's count; the firmware's task loop calls it. A board without one ignores it. */
void hal_watchdog_feed(void);

/* ---- Simulation hooks (real boards return WDR_E_UNSUPPORTED) ------------------------------ */

/* Light every pixel with the same photocurrent, in amperes (caps has HAL_CAP_ILLUMINANT).
 * @retval WDR_OK  @retval WDR_E_UNSUPPORTED  @retval WDR_E_INVAL negative or not finite */
int hal_set_illuminant(double amps);
/* Take the uniform light away: the pixels see the scene they saw before hal_set_illuminant
 * (nothing changes when no uniform light is on). @retval WDR_OK  @retval WDR_E_UNSUPPORTED
 * @retval WDR_E_NOMEM */
int hal_restore_scene(void);

#endif
