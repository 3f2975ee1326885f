/* wdrctl's firmware-image commands: what the file commands (cmd_fw_image.c: fw sign, fw info)
 * share with the board commands (cmd_fw.c: fw upload, fw status, fw confirm, fw revert, reboot). */
#ifndef WDRCTL_FW_H
#define WDRCTL_FW_H
#include "fw_sign.h"
#include <stddef.h>
#include <stdint.h>

/* Read an image or application file; prints why not. @return a sysexits code */
int wdrctl_fw_read_image(const char *path, uint8_t **buf, size_t *len);

/* Check img (wdr_fw_image_check) and print what fw info prints, text or JSON; key may be NULL.
 * @return EX_OK when everything checked holds, else the check's code with its message printed */
int wdrctl_fw_print_image(const char *path, const uint8_t *img, size_t len, const wdr_fw_key *key, int json);

/* sysexits code of a wdr_fw_image_check result. */
int wdrctl_fw_check_exit(int rc);

#endif
