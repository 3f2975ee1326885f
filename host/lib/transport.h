/* Byte-stream link between the host and a board: the protocol bytes as-is (firmware/SPEC.md),
 * over a local socket to the simulated board or over the bulk endpoints of a real board.
 * Every call that waits takes a timeout; nothing here blocks forever. */
#ifndef WDR_TRANSPORT_H
#define WDR_TRANSPORT_H
#include "wdr_err.h"
#include <stddef.h>
#include <stdint.h>

/* USB identity of a wdrcam board. 1209 is the pid.codes open-hardware vendor; 0001 is its
 * test PID, for lab boards until a product PID is allocated. The interface is vendor-specific
 * with subclass 'W' so that other test-PID gadgets on the same bus are not mistaken for ours. */
#define WDR_USB_VID 0x1209
#define WDR_USB_PID 0x0001
#define WDR_USB_CLASS 0xff
#define WDR_USB_SUBCLASS 0x57
#define WDR_USB_PROTOCOL 0x01
#define WDR_USB_UDEV_RULE "host/udev/60-wdrcam.rules"

/* Host-only failures (WDR_E_ABSENT, WDR_E_DENIED) are in wdr_err.h with the rest. */

typedef struct wdr_transport wdr_transport;

/* What a backend implements; the public functions below check arguments once, here. */
typedef struct wdr_transport_ops {
    int (*send)(wdr_transport *t, const uint8_t *buf, size_t len, int timeout_ms);
    int (*recv)(wdr_transport *t, uint8_t *buf, size_t cap, int timeout_ms);
    void (*close)(wdr_transport *t);
} wdr_transport_ops;

struct wdr_transport {
    const wdr_transport_ops *ops;
    char name[160]; /* the address, for messages */
};

/* Open a board by address: "sim:/path/to.sock" (the simulated board's socket), "usb" (the only
 * wdrcam USB board), "usb:BUS-ADDR" (e.g. "usb:1-7"), "serial:/dev/ttyACM0[@BAUD]" (a board on a
 * serial port), "unix:/path" or "tcp:HOST:PORT" (an emulated board's UART, tests/target). err
 * gets a message naming the address.
 * @retval WDR_OK
 * @retval WDR_E_INVAL   malformed address
 * @retval WDR_E_ABSENT  nothing answers at that address
 * @retval WDR_E_DENIED  permission denied (the message names the udev rule to install)
 * @retval WDR_E_BUSY    the USB interface is claimed by another program
 * @retval WDR_E_IO      other OS or libusb failure
 * @retval WDR_E_NOMEM */
int wdr_transport_open(const char *address, wdr_transport **out, char *err, int errlen);

/* The same, giving up a connect that is not accepted within timeout_ms (a socket whose listener
 * never accepts: its queue is full). wdr_transport_open waits WDR_TRANSPORT_CONNECT_MS.
 * @retval as wdr_transport_open; WDR_E_TIMEOUT  the connection was not accepted in time */
int wdr_transport_open_within(const char *address, int timeout_ms, wdr_transport **out, char *err, int errlen);
#define WDR_TRANSPORT_CONNECT_MS 2000

/* Wrap a connected stream socket (e.g. one end of a socketpair, for tests); takes ownership.
 * @retval WDR_OK, WDR_E_INVAL (fd < 0), WDR_E_NOMEM */
int wdr_transport_from_fd(int fd, const char *name, wdr_transport **out);

/* Send all len bytes within timeout_ms.
 * @retval WDR_OK
 * @retval WDR_E_TIMEOUT  the board stopped taking bytes (some may have been sent)
 * @retval WDR_E_IO       the board disconnected */
int wdr_transport_send(wdr_transport *t, const void *buf, size_t len, int timeout_ms);

/* Receive up to cap bytes, waiting at most timeout_ms for the first.
 * @retval >0             bytes received
 * @retval WDR_E_TIMEOUT  nothing arrived in time
 * @retval WDR_E_IO       the board disconnected */
int wdr_transport_recv(wdr_transport *t, void *buf, size_t cap, int timeout_ms);

/* Receive exactly len bytes within timeout_ms in all; same errors as wdr_transport_recv. */
int wdr_transport_recv_exact(wdr_transport *t, void *buf, size_t len, int timeout_ms);

/* Close and free; NULL is allowed. */
void wdr_transport_close(wdr_transport *t);

const char *wdr_transport_name(const wdr_transport *t);

/* Message for a code of wdr_err.h or of enum wdr_transport_err. */
const char *wdr_transport_strerror(int err);

/* One wdrcam board on the USB bus, for `wdrctl devices`. */
typedef struct wdr_usb_board {
    int bus, address;
    uint16_t vid, pid;
    char serial[64];
    char address_text[32]; /* "usb:BUS-ADDR" */
} wdr_usb_board;

/* List wdrcam boards on the USB bus; returns how many (at most max), or WDR_E_IO. */
int wdr_transport_list_usb(wdr_usb_board *out, int max, char *err, int errlen);

/* Milliseconds of a monotonic clock, for deadlines. */
int64_t wdr_transport_now_ms(void);

/* Backends (transport_socket.c, transport_usb.c); use wdr_transport_open instead. */
int wdr_transport_open_socket(const char *path, int timeout_ms, wdr_transport **out, char *err, int errlen);
int wdr_transport_open_usb(const char *bus_addr, wdr_transport **out, char *err, int errlen);
/* Byte streams (transport_serial.c): "PATH[@BAUD]" a tty in raw 8N1 (default 115200 baud);
 * a unix socket path or "HOST:PORT" to an emulated board's UART (QEMU -serial ...,server). */
int wdr_transport_open_serial(const char *spec, wdr_transport **out, char *err, int errlen);
int wdr_transport_open_unix(const char *path, int timeout_ms, wdr_transport **out, char *err, int errlen);
int wdr_transport_open_tcp(const char *spec, int timeout_ms, wdr_transport **out, char *err, int errlen);
/* connect() of a socket fd within timeout_ms (transport_connect.c); the fd is left non-blocking.
 * @return 0, or an errno value (ETIMEDOUT: not accepted in time) */
int wdr_socket_connect(int fd, const void *addr, unsigned addr_len, int timeout_ms);

#endif
