/* End-to-end rig: a real wdr-simboard child process on a socket in a private temp folder,
 * a protocol client connected to it, and the Reinhard LUT built the way `wdrctl lut build`
 * builds it. The child's stdin is a pipe: if the test dies, the board ends too. */
#ifndef E2E_BOARD_H
#define E2E_BOARD_H
#include "board.h"
#include "ramp.h"
#include "transport_client.h"
#include <stddef.h>
#include <stdint.h>
#include <sys/types.h>

typedef struct e2e_board {
    char dir[64];            /* mkdtemp folder: socket, scene, files */
    char socket_path[128];
    char address[160];       /* "sim:<socket_path>" */
    char scene_path[128];
    const char *flash_path;  /* --flash FILE, or NULL (RAM) */
    const char *firmware_path; /* --firmware IMG (a factory image for a blank board), or NULL */
    pid_t pid;
    int stdin_fd;            /* write end of the child's stdin */
    wdr_board board;
    wdr_transport *t;
    wdr_client *c;
} e2e_board;

/* Write the default scene (sim/scenes/window.json) with every fixed-pattern and temporal effect
 * off and the quantisations on, start wdr-simboard on board_name, connect. 0 on success. */
int e2e_start(e2e_board *e, const char *board_name);

/* The same, with the board's flash kept in flash_path (which outlives e2e_stop). */
int e2e_start_with_flash(e2e_board *e, const char *board_name, const char *flash_path);

/* The same, flashing firmware_path into slot A of the blank image flash (--firmware). */
int e2e_start_with_firmware(e2e_board *e, const char *board_name, const char *flash_path, const char *firmware_path);

/* The same, with the scene file scene_json (its bytes copied into the rig's folder) instead of the
 * quiet default, and the flash kept in flash_path if not NULL. */
int e2e_start_scene(e2e_board *e, const char *board_name, const char *scene_json, const char *flash_path);

/* Disconnect, end the child (EOF on its stdin, then SIGTERM after a grace period), remove the folder. */
void e2e_stop(e2e_board *e);

/* Reinhard (scene statistics from the board's defaults) as LUT bytes (malloc'd), and its view. */
int e2e_reinhard_lut(const wdr_board *b, uint8_t **bytes, size_t *len);

/* The software tone-mapped scene: each pixel's photocurrent through the ideal pixel driven by
 * lut (wdr_ramp_lut_ideal_response), the nominal source follower and the board's ADC line, rounded.
 * codes gets width*height values. */
int e2e_software_frame(const wdr_board *b, const char *scene_path, const uint8_t *lut, size_t lut_len,
                       uint16_t *codes);

/* The software model's code for one photocurrent. */
uint16_t e2e_software_code(const wdr_board *b, const uint8_t *lut, size_t lut_len, double amps);

/* Wait up to ms for the child to end; its exit status (0 clean), or -1 if it is still running
 * or died by a signal. The child is then gone (e2e_stop has nothing left to end). */
int e2e_wait_exit(e2e_board *e, int ms);

/* Connect again (after a wdrctl run had the board). 0 on success. */
int e2e_reconnect(e2e_board *e);

/* Run a program with args (argv[0] included), bounded by a deadline; its exit code, or -1. */
int e2e_run(char *const argv[], int deadline_s);

#endif
