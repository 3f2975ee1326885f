/* Test-only API of the simulated board: what a test bench or wdr-simboard does to the board
 * from outside (light, power, flash faults, the clock). The firmware never includes this; it
 * sees only hal/hal.h.
 *
 * Time is virtual: it starts at 0 on hal_init, moves only when the firmware waits
 * (hal_delay_ns, hal_wait_for_event jumping to the next scheduled happening, an ADC conversion
 * taking the board's row time), and is identical from run to run for the same seeds. */
#ifndef HAL_SIM_EMUL_H
#define HAL_SIM_EMUL_H
#include "board.h"
#include <stddef.h>
#include <stdint.h>

typedef struct wdr_sim wdr_sim;

typedef struct hal_sim_config {
    const wdr_board *board;   /* copied */
    uint64_t seed;            /* chip seed: the fixed-pattern draw */
    uint64_t frame_seed;      /* temporal noise: frame k uses a seed derived from this and k */
    const char *socket_path;  /* AF_UNIX path the "USB" listens on; NULL: no USB link */
    const char *flash_path;   /* file that keeps the flash between runs; NULL: RAM only */
    uint32_t flash_block_size, flash_block_count, flash_prog_size; /* 0: defaults below */
    const char *image_flash_path; /* file that keeps the image flash (wdr-simboard: FLASH.images); NULL: RAM */
    const char *hand_light_path;  /* a real board's light: no HAL_CAP_ILLUMINANT, and the photocurrent (A)
                                     or "scene" a person sets, read from this file at each integration's
                                     start (hal_sim_hand_light.c); NULL: the board lights itself */
} hal_sim_config;

#define HAL_SIM_FLASH_BLOCK_SIZE 4096u
#define HAL_SIM_FLASH_BLOCK_COUNT 8192u /* 32 MiB: A/B slots of a VGA basis-8 calibration table (9.8 MB) */
#define HAL_SIM_FLASH_PROG_SIZE 128u /* the firmware's slot format needs <= 128 */

/* The image flash (SPEC.md, "Image flash and boot"): the mps2-an500's geometry, 2 MiB. */
#define HAL_SIM_IMAGE_BLOCK_SIZE 4096u
#define HAL_SIM_IMAGE_BLOCK_COUNT 512u
#define HAL_SIM_IMAGE_PROG_SIZE 16u

/* Build the board: sensor chip, flash, socket. Call before hal_init; again only after
 * hal_sim_teardown. err names the file or path at fault.
 * @retval WDR_OK, WDR_E_INVAL (bad geometry or path), WDR_E_IO (socket or flash file), WDR_E_NOMEM */
int hal_sim_setup(const hal_sim_config *cfg, char *err, int errlen);

/* Release everything hal_sim_setup made (unlinks the socket path). */
void hal_sim_teardown(void);

/* The simulated sensor, to choose effects or threads (owned by the board). */
wdr_sim *hal_sim_sensor(void);

/* ---- Light ------------------------------------------------------------------------------ */

/* Same as the firmware's hal_set_illuminant: one photocurrent (A) on every pixel. */
int hal_sim_set_illuminant(double amps);

/* A width*height photocurrent map (A), rows top-down; copied by the simulator. */
int hal_sim_set_scene(const float *amps);

/* ---- Power and flash faults ------------------------------------------------------------- */

/* Cut power during the n-th flash erase or program from now (1 = the next one); 0 disarms.
 * The interrupted operation leaves its first half done (a torn write or a half-erased block);
 * it and every later flash call return WDR_E_POWER until hal_sim_reboot. */
void hal_sim_cut_power_at(uint64_t n);

/* The same with the shape of the tear the cut leaves: enum nor_tear of nor_emul.h (nothing
 * done, first half, second half, bits partly programmed or erased). */
void hal_sim_cut_power_tear(uint64_t n, int tear);

/* Make the n-th erase or program from now fail with WDR_E_IO, leaving flash untouched; 0 disarms. */
void hal_sim_fail_flash_at(uint64_t n);

/* Erases and programs since setup, counted as nor_emul.h counts them (reads are not counted:
 * they change nothing). */
uint64_t hal_sim_flash_ops(void);

/* 1 after a power cut, until hal_sim_reboot. */
int hal_sim_power_lost(void);

/* Power back on: flash keeps its bytes; events, ramp, ADC and USB transfer state are cleared
 * and the clock restarts at 0, as after a real reset. The caller then reruns the firmware's init. */
void hal_sim_reboot(void);

/* Erase the whole flash to 0xFF (a factory-new chip). */
void hal_sim_flash_reset(void);

/* Direct view of the flash bytes, for invariant checks. */
const uint8_t *hal_sim_flash_bytes(size_t *size);

/* ---- Image flash and boot ----------------------------------------------------------------
 * hal_init is the reset: it runs the bootloader's logic (firmware/boot, wdr_boot_decide) over
 * the image flash and leaves the record hal_boot_record_get returns (none when nothing is
 * bootable: the firmware then runs unversioned). The application bytes are opaque here: the
 * built-in firmware runs as the chosen image, with its header's version. */

/* 1 when every byte of the image flash is erased (a blank board). */
int hal_sim_image_flash_blank(void);

/* Write a whole signed image into slot A with an empty state log: a factory image, as a
 * programmer flashes a blank board. Not checked here: the boot decides.
 * @retval WDR_OK  @retval WDR_E_TOO_LARGE beyond slot A  @retval WDR_E_IO  @retval WDR_E_POWER */
int hal_sim_image_flash_write_factory(const uint8_t *image, size_t len);

/* Direct view of the image flash bytes (tests). */
uint8_t *hal_sim_image_flash_bytes(size_t *size);

/* Print each boot's decision on stderr (wdr-simboard). */
void hal_sim_set_boot_log(int on);

/* 1 once after the firmware called hal_reset (the flag is taken): the loop then reruns
 * hal_init and the firmware's init, as the board's reset would. */
int hal_sim_take_reset(void);

/* hal_watchdog_feed calls since setup. */
uint64_t hal_sim_watchdog_feeds(void);

/* ---- USB link faults (callable from another thread while the firmware is served (simboard_loop.h)) ------------ */

/* Lose the next n bytes the host sends, as if their packets vanished on the bus. */
void hal_sim_usb_drop_rx(uint32_t n);

/* Flip the k-th byte (1 = the next) that the board sends from now. */
void hal_sim_usb_corrupt_tx(uint32_t k);

/* Pull the cable: the host's connection closes at the board's next look at the link. */
void hal_sim_usb_unplug(void);

/* ---- Clock, frames and the loop --------------------------------------------------------- */

uint64_t hal_sim_time_ns(void);

/* Move the virtual clock forward (as if the board idled); due events are posted. */
void hal_sim_advance_ns(uint64_t ns);

/* Frames exposed since setup. */
uint64_t hal_sim_frames_exposed(void);

/* Ask hal_wait_for_event to return without an event (from a signal handler or another
 * thread); hal_sim_stop_requested tells the loop to end. */
void hal_sim_request_stop(void);
int hal_sim_stop_requested(void);

/* Exit the serve loop when the first host disconnects (wdr-simboard --once). */
void hal_sim_set_exit_on_disconnect(int on);

/* Also end the loop when this descriptor reaches EOF (a pipe from the parent); -1: none. */
void hal_sim_watch_eof(int fd);

#endif
