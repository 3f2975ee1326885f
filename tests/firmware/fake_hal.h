/* A test board behind hal/hal.h: virtual time, strict NOR flash with an operation counter that
 * cuts power, USB endpoints as byte FIFOs, an ADC that returns a known pattern. Test-only API
 * (fb_*), separate from the HAL the firmware sees. One board per process. */
#ifndef FAKE_BOARD_H
#define FAKE_BOARD_H
#include <stddef.h>
#include <stdint.h>

struct wdr_boot_record;

#define FB_WIDTH 64
#define FB_HEIGHT 48
#define FB_SENSOR_ID 77u
#define FB_ADC_BITS 12
#define FB_DAC_BITS 12
#define FB_ROW_TIME_NS 20000u
#define FB_BLOCK_SIZE 4096u
#define FB_BLOCK_COUNT 64u
#define FB_PROG_SIZE 16u
#define FB_BOARD_NAME "fake-board"
/* The image flash: 2 floor blocks and two slots of 31 blocks (30 for the image: 120 KiB). */
#define FB_IMG_BLOCK_SIZE 4096u
#define FB_IMG_BLOCK_COUNT 64u
#define FB_IMG_PROG_SIZE 16u

/* Power on with erased flash (fresh board). */
void fb_init(void);

/* Power off and on: flash keeps its bytes; RAM state, queues, FIFOs and time restart; armed
 * flash faults are disarmed. */
void fb_power_cycle(void);

/* The flash is the NOR emulator of hal/sim/nor_emul.h, which counts operations the one way
 * it documents; here op numbers count from this power-on, 0-based.
 * Cut power at flash operation number op (erase and program count; -1: never).
 * torn: the cut operation does half its work (half the bytes programmed, half a block erased). */
void fb_cut_power_at(long op, int torn);
/* The same with the shape of the tear: enum nor_tear (none, first half, second half, bits). */
void fb_cut_power_tear(long op, int tear);
/* Make flash operation op fail with WDR_E_IO, flash untouched (-1: never). */
void fb_fail_flash_at(long op);
long fb_flash_ops(void);   /* operations since fb_init or fb_power_cycle */
int fb_power_lost(void);

/* Raw flash, for tests that corrupt or restore it on purpose. The next fb_power_cycle takes
 * which program units are in use from the bytes (any byte not 0xFF). */
uint8_t *fb_flash(void);

/* The ADC code of a pixel in the test pattern (before any correction). */
uint16_t fb_pattern(int row, int col);

/* Host side of the USB link. */
void fb_host_write(const void *bytes, size_t n);
size_t fb_host_read(uint8_t *buf, size_t cap);

/* Whether a timer or the ramp is still due, so that hal_wait_for_event has something to wait for. */
int fb_scheduled(void);

/* Make hal_adc_read_row fail with WDR_E_IO for this row (-1: never). */
void fb_fail_adc_row(int row);

/* ---- Image flash, boot record, reset ---------------------------------------------------------
 * The image flash is a second NOR emulator (its own counter, not armed by fb_cut_power_at). */
uint8_t *fb_image_flash(void);
/* Whether the board has an image flash (1 by default; 0: hal_image_flash_* UNSUPPORTED). */
void fb_set_image_flash(int present);
/* What hal_boot_record_get returns from now (NULL: not started by a bootloader). */
void fb_set_boot_record(const struct wdr_boot_record *r);
/* The bootloader's part of a reset: wdr_boot_decide over the image flash with this board's
 * policy, then the boot record it would pass (none when nothing is bootable), with cause.
 * @return the slot chosen, or -1 */
int fb_boot(uint8_t cause);
/* hal_reset calls since fb_init, and the cause of the last. */
int fb_resets(void);
int fb_last_reset_cause(void);
/* hal_watchdog_feed calls since fb_init. */
long fb_watchdog_feeds(void);
/* Bytes the board has handed to bulk IN since fb_init, and how many it had at the last hal_reset. */
long fb_tx_bytes(void);
long fb_tx_bytes_at_reset(void);

double fb_illuminant(void);
uint64_t fb_ramp_ticks(void); /* t_integration_ticks of the last ramp played */

#endif
