/* vm_usbprobe: USB requests that wdrctl never makes, for the VM test's robustness probes.
 *
 *   vm_usbprobe control   vendor requests to the interface, IN then OUT then IN again: each
 *                         must stall (LIBUSB_ERROR_PIPE) at once; a timeout means nobody on
 *                         the board answers ep0 any more
 *   vm_usbprobe reset     a USB bus reset of the board (libusb_reset_device)
 *   vm_usbprobe speed     prints the link speed: low, full, high, super or super+
 * Exit 0 when the board behaved, 1 when it did not, 69 (EX_UNAVAILABLE) with no board. */
#include "transport.h"
#include <libusb.h>
#include <stdio.h>
#include <string.h>
#include <sysexits.h>

#define CONTROL_TIMEOUT_MS 2000

static libusb_device_handle *open_board(libusb_context *ctx)
{
    libusb_device_handle *h = libusb_open_device_with_vid_pid(ctx, WDR_USB_VID, WDR_USB_PID);
    if (!h)
        fprintf(stderr, "vm_usbprobe: no %04x:%04x device\n", WDR_USB_VID, WDR_USB_PID);
    return h;
}

/* One vendor request to interface 0; 0 when it stalled as it must. */
static int expect_stall(libusb_device_handle *h, uint8_t type, const char *what)
{
    unsigned char buf[4] = {1, 2, 3, 4};
    int rc = libusb_control_transfer(h, type, 1, 0, 0, buf, sizeof buf, CONTROL_TIMEOUT_MS);
    int ok = rc == LIBUSB_ERROR_PIPE;
    printf("control %s (bmRequestType 0x%02x): %s%s\n", what, type, rc >= 0 ? "accepted" : libusb_error_name(rc),
           ok ? " (stalled, as it must)" : " (must stall)");
    return ok ? 0 : 1;
}

static int probe_control(libusb_device_handle *h)
{
    int bad = expect_stall(h, LIBUSB_ENDPOINT_IN | LIBUSB_REQUEST_TYPE_VENDOR | LIBUSB_RECIPIENT_INTERFACE, "IN");
    bad += expect_stall(h, LIBUSB_ENDPOINT_OUT | LIBUSB_REQUEST_TYPE_VENDOR | LIBUSB_RECIPIENT_INTERFACE, "OUT");
    bad += expect_stall(h, LIBUSB_ENDPOINT_IN | LIBUSB_REQUEST_TYPE_VENDOR | LIBUSB_RECIPIENT_INTERFACE, "IN again");
    return bad ? 1 : 0;
}

static int probe_reset(libusb_device_handle *h)
{
    int rc = libusb_reset_device(h);
    printf("bus reset: %s\n", rc == 0 ? "done" : libusb_error_name(rc));
    return rc == 0 || rc == LIBUSB_ERROR_NOT_FOUND ? 0 : 1; /* NOT_FOUND: re-enumerated anew */
}

static int probe_speed(libusb_device_handle *h)
{
    static const char *names[] = {"unknown", "low", "full", "high", "super", "super+"};
    int s = libusb_get_device_speed(libusb_get_device(h));
    printf("%s\n", s >= 0 && s < (int)(sizeof names / sizeof names[0]) ? names[s] : "unknown");
    return 0;
}

int main(int argc, char **argv)
{
    if (argc != 2 || (strcmp(argv[1], "control") && strcmp(argv[1], "reset") && strcmp(argv[1], "speed"))) {
        fprintf(stderr, "usage: vm_usbprobe control|reset|speed\n");
        return EX_USAGE;
    }
    libusb_context *ctx;
    if (libusb_init(&ctx) != 0)
        return EX_UNAVAILABLE;
    libusb_device_handle *h = open_board(ctx);
    int rc = EX_UNAVAILABLE;
    if (h) {
        rc = !strcmp(argv[1], "control") ? probe_control(h)
             : !strcmp(argv[1], "reset") ? probe_reset(h)
                                         : probe_speed(h);
        libusb_close(h);
    }
    libusb_exit(ctx);
    return rc;
}
