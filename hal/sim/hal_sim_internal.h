/* Shared state of the simulated board's parts (core, flash, USB socket); not for tests. */
#ifndef HAL_SIM_INTERNAL_H
#define HAL_SIM_INTERNAL_H
#include "hal.h"
#include "hal_sim_emul.h"
#include "nor_emul.h"

/* Post an event to the firmware's queue (dropped when full, as on a real board). */
void hal_sim_post(uint8_t type, uint32_t arg);

/* A NOR emulator over heap buffers, kept in a file when a path is given (what: "flash",
 * "image flash", for messages). */
typedef struct sim_nor_file {
    nor_emul nor;
    uint8_t *bytes, *programmed;
    int fd; /* backing file, or -1 */
    const char *what;
} sim_nor_file;
int sim_nor_file_open(sim_nor_file *s, const hal_flash_geometry *g, const char *path, const char *what, char *err,
                      int errlen);
void sim_nor_file_close(sim_nor_file *s);

/* Flash part (hal_sim_flash.c). */
int hal_sim_flash_setup(const hal_sim_config *cfg, char *err, int errlen);
void hal_sim_flash_teardown(void);
void hal_sim_flash_reboot(void);

/* Image flash part (hal_sim_image.c), and the boot the bootloader would do (hal_sim_boot.c). */
int hal_sim_image_setup(const hal_sim_config *cfg, char *err, int errlen);
void hal_sim_image_teardown(void);
void hal_sim_image_reboot(void);
const nor_emul *hal_sim_image_nor(void);
void hal_sim_boot_run(void);
void hal_sim_boot_teardown(void);

/* USB-over-socket part (hal_sim_usb.c). */
int hal_sim_usb_setup(const char *path, char *err, int errlen);
void hal_sim_usb_teardown(void);
void hal_sim_usb_reboot(void);
/* Move bytes without blocking, or wait up to timeout_ms of real time for the socket;
 * posts USB_RX, USB_TX_DONE and USB_RESET as things happen. */
void hal_sim_usb_pump(int timeout_ms);
/* 1 while a bulk IN transfer is still being written to the host. */
int hal_sim_usb_tx_pending(void);

/* A real board's light, set by hand in a file (hal_sim_hand_light.c): setup (NULL: self-lit), on,
 * and apply (read the file, light the sensor as it says; at each integration's start). */
void hal_sim_hand_light_setup(const char *path);
int hal_sim_hand_light_on(void);
void hal_sim_hand_light_apply(void);
/* The uniform light, whoever sets it (the firmware's command, the emulator, the hand light). */
int hal_sim_light_uniform(double amps);

/* Loop control shared with the USB part. */
extern int hal_sim_exit_on_disconnect;
extern int hal_sim_eof_fd;

#endif
