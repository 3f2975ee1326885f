/* USB backend (libusb-1.0): finds a wdrcam board by VID/PID and interface class, claims the
 * interface and moves the protocol bytes over its bulk endpoints with timeouts.
 * Bulk IN is read in large transfers into a buffer and handed out as a byte stream, so a
 * caller asking for a few header bytes never overflows a device packet. */
#include "transport.h"
#include "wdr_err.h"
#include <libusb.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define USB_IN_BUFFER 16384 /* a multiple of every bulk max packet size */

typedef struct usb_transport {
    wdr_transport base; /* first: the public handle points here */
    libusb_context *ctx;
    libusb_device_handle *dev;
    int interface;
    uint8_t ep_in, ep_out;
    uint8_t in_buf[USB_IN_BUFFER];
    size_t in_pos, in_len;
} usb_transport;

static int from_libusb(int rc)
{
    switch (rc) {
    case LIBUSB_ERROR_TIMEOUT: return WDR_E_TIMEOUT;
    case LIBUSB_ERROR_ACCESS: return WDR_E_DENIED;
    case LIBUSB_ERROR_BUSY: return WDR_E_BUSY;
    case LIBUSB_ERROR_NO_DEVICE:
    case LIBUSB_ERROR_NOT_FOUND: return WDR_E_ABSENT;
    case LIBUSB_ERROR_NO_MEM: return WDR_E_NOMEM;
    default: return WDR_E_IO;
    }
}

/* The wdrcam interface of a configuration: vendor class, subclass 'W'; -1 if none. */
static int find_interface(const struct libusb_config_descriptor *cfg, uint8_t *ep_in, uint8_t *ep_out)
{
    for (int i = 0; i < cfg->bNumInterfaces; i++) {
        const struct libusb_interface_descriptor *d = &cfg->interface[i].altsetting[0];
        if (d->bInterfaceClass != WDR_USB_CLASS || d->bInterfaceSubClass != WDR_USB_SUBCLASS)
            continue;
        *ep_in = *ep_out = 0;
        for (int e = 0; e < d->bNumEndpoints; e++) {
            const struct libusb_endpoint_descriptor *ep = &d->endpoint[e];
            if ((ep->bmAttributes & LIBUSB_TRANSFER_TYPE_MASK) != LIBUSB_TRANSFER_TYPE_BULK)
                continue;
            if (ep->bEndpointAddress & LIBUSB_ENDPOINT_IN)
                *ep_in = ep->bEndpointAddress;
            else
                *ep_out = ep->bEndpointAddress;
        }
        if (*ep_in && *ep_out)
            return d->bInterfaceNumber;
    }
    return -1;
}

static int is_wdrcam(libusb_device *dev, int *iface, uint8_t *ep_in, uint8_t *ep_out)
{
    struct libusb_device_descriptor dd;
    if (libusb_get_device_descriptor(dev, &dd) != 0 || dd.idVendor != WDR_USB_VID || dd.idProduct != WDR_USB_PID)
        return 0;
    struct libusb_config_descriptor *cfg;
    if (libusb_get_active_config_descriptor(dev, &cfg) != 0)
        return 0;
    *iface = find_interface(cfg, ep_in, ep_out);
    libusb_free_config_descriptor(cfg);
    return *iface >= 0;
}

/* "BUS-ADDR" -> numbers; 0 on a malformed text. */
static int parse_bus_addr(const char *text, int *bus, int *addr)
{
    char tail;
    return sscanf(text, "%d-%d%c", bus, addr, &tail) == 2 && *bus >= 0 && *addr > 0;
}

static int usb_send(wdr_transport *t, const uint8_t *buf, size_t len, int timeout_ms)
{
    usb_transport *u = (usb_transport *)t;
    int64_t deadline = wdr_transport_now_ms() + timeout_ms;
    size_t done = 0;
    while (done < len) {
        int64_t left = deadline - wdr_transport_now_ms();
        if (left <= 0)
            return WDR_E_TIMEOUT;
        int chunk = len - done > 65536 ? 65536 : (int)(len - done), sent = 0;
        int rc = libusb_bulk_transfer(u->dev, u->ep_out, (uint8_t *)buf + done, chunk, &sent, (unsigned)left);
        done += (size_t)(sent > 0 ? sent : 0);
        if (rc == LIBUSB_ERROR_NO_DEVICE || rc == LIBUSB_ERROR_PIPE || rc == LIBUSB_ERROR_IO)
            return WDR_E_IO;
        if (rc != 0 && rc != LIBUSB_ERROR_TIMEOUT)
            return from_libusb(rc);
        if (rc == LIBUSB_ERROR_TIMEOUT && done < len)
            return WDR_E_TIMEOUT;
    }
    return WDR_OK;
}

/* One bulk IN transfer into the buffer; zero-length packets (ends of exact-size transfers)
 * carry nothing, so they are read past until the deadline. */
static int fill_in_buffer(usb_transport *u, int timeout_ms)
{
    int64_t deadline = wdr_transport_now_ms() + timeout_ms;
    for (;;) {
        int64_t left = deadline - wdr_transport_now_ms();
        int got = 0;
        int rc = libusb_bulk_transfer(u->dev, u->ep_in, u->in_buf, USB_IN_BUFFER, &got, (unsigned)(left > 0 ? left : 1));
        if (got > 0) { /* a timeout may still have delivered bytes */
            u->in_pos = 0;
            u->in_len = (size_t)got;
            return WDR_OK;
        }
        if (rc == LIBUSB_ERROR_TIMEOUT || (rc == 0 && left <= 0))
            return WDR_E_TIMEOUT;
        if (rc != 0)
            return rc == LIBUSB_ERROR_NO_DEVICE || rc == LIBUSB_ERROR_PIPE || rc == LIBUSB_ERROR_IO ? WDR_E_IO
                                                                                                   : from_libusb(rc);
    }
}

static int usb_recv(wdr_transport *t, uint8_t *buf, size_t cap, int timeout_ms)
{
    usb_transport *u = (usb_transport *)t;
    if (u->in_pos == u->in_len) {
        int rc = fill_in_buffer(u, timeout_ms);
        if (rc != WDR_OK)
            return rc;
    }
    size_t n = u->in_len - u->in_pos;
    if (n > cap)
        n = cap;
    if (n > 0x7fffffff)
        n = 0x7fffffff;
    memcpy(buf, u->in_buf + u->in_pos, n);
    u->in_pos += n;
    return (int)n;
}

static void usb_close(wdr_transport *t)
{
    usb_transport *u = (usb_transport *)t;
    if (u->dev) {
        libusb_release_interface(u->dev, u->interface);
        libusb_close(u->dev);
    }
    if (u->ctx)
        libusb_exit(u->ctx);
    free(u);
}

static const wdr_transport_ops usb_ops = {usb_send, usb_recv, usb_close};

static int open_error(int rc, libusb_device *dev, char *err, int errlen)
{
    int code = from_libusb(rc);
    int bus = libusb_get_bus_number(dev), addr = libusb_get_device_address(dev);
    if (code == WDR_E_DENIED)
        snprintf(err, (size_t)errlen,
                 "permission denied opening USB board %04x:%04x at usb:%d-%d; install the udev rule: "
                 "sudo cp " WDR_USB_UDEV_RULE " /etc/udev/rules.d/ && sudo udevadm control --reload && "
                 "sudo udevadm trigger (then replug the board)",
                 WDR_USB_VID, WDR_USB_PID, bus, addr);
    else if (code == WDR_E_BUSY)
        snprintf(err, (size_t)errlen, "USB board at usb:%d-%d is claimed by another program", bus, addr);
    else
        snprintf(err, (size_t)errlen, "cannot open USB board at usb:%d-%d: %s", bus, addr, libusb_strerror(rc));
    return code;
}

/* Open and claim dev into u. */
static int claim(usb_transport *u, libusb_device *dev, char *err, int errlen)
{
    int rc = libusb_open(dev, &u->dev);
    if (rc != 0) {
        u->dev = NULL;
        return open_error(rc, dev, err, errlen);
    }
    libusb_set_auto_detach_kernel_driver(u->dev, 1);
    rc = libusb_claim_interface(u->dev, u->interface);
    if (rc != 0) {
        libusb_close(u->dev);
        u->dev = NULL;
        return open_error(rc, dev, err, errlen);
    }
    snprintf(u->base.name, sizeof u->base.name, "usb:%d-%d", libusb_get_bus_number(dev),
             libusb_get_device_address(dev));
    return WDR_OK;
}

static int pick_and_claim(usb_transport *u, const char *bus_addr, char *err, int errlen)
{
    int want_bus = -1, want_addr = -1;
    if (bus_addr && !parse_bus_addr(bus_addr, &want_bus, &want_addr)) {
        snprintf(err, (size_t)errlen, "bad USB address 'usb:%s': expected usb:BUS-ADDR, e.g. usb:1-7", bus_addr);
        return WDR_E_INVAL;
    }
    libusb_device **list;
    ssize_t n = libusb_get_device_list(u->ctx, &list);
    if (n < 0) {
        snprintf(err, (size_t)errlen, "cannot list USB devices: %s", libusb_strerror((int)n));
        return WDR_E_IO;
    }
    int rc = WDR_E_ABSENT;
    for (ssize_t i = 0; i < n && rc == WDR_E_ABSENT; i++) {
        if (want_bus >= 0 && (libusb_get_bus_number(list[i]) != want_bus ||
                              libusb_get_device_address(list[i]) != want_addr))
            continue;
        if (is_wdrcam(list[i], &u->interface, &u->ep_in, &u->ep_out))
            rc = claim(u, list[i], err, errlen);
    }
    libusb_free_device_list(list, 1);
    if (rc == WDR_E_ABSENT)
        snprintf(err, (size_t)errlen, "no wdrcam USB board (%04x:%04x) %s%s: is it plugged in? (`wdrctl devices` lists boards)",
                 WDR_USB_VID, WDR_USB_PID, bus_addr ? "at usb:" : "found", bus_addr ? bus_addr : "");
    return rc;
}

int wdr_transport_open_usb(const char *bus_addr, wdr_transport **out, char *err, int errlen)
{
    *out = NULL;
    usb_transport *u = calloc(1, sizeof *u);
    if (!u)
        return WDR_E_NOMEM;
    u->base.ops = &usb_ops;
    int rc = libusb_init(&u->ctx);
    if (rc != 0) {
        snprintf(err, (size_t)errlen, "cannot start libusb: %s", libusb_strerror(rc));
        free(u);
        return WDR_E_IO;
    }
    rc = pick_and_claim(u, bus_addr, err, errlen);
    if (rc != WDR_OK) {
        usb_close(&u->base);
        return rc;
    }
    *out = &u->base;
    return WDR_OK;
}

static void describe(libusb_device *dev, wdr_usb_board *b)
{
    struct libusb_device_descriptor dd;
    memset(b, 0, sizeof *b);
    libusb_get_device_descriptor(dev, &dd);
    b->bus = libusb_get_bus_number(dev);
    b->address = libusb_get_device_address(dev);
    b->vid = dd.idVendor;
    b->pid = dd.idProduct;
    snprintf(b->address_text, sizeof b->address_text, "usb:%d-%d", b->bus, b->address);
    libusb_device_handle *h;
    /* The serial needs the device open; without permission it stays "?" rather than failing. */
    if (dd.iSerialNumber && libusb_open(dev, &h) == 0) {
        libusb_get_string_descriptor_ascii(h, dd.iSerialNumber, (unsigned char *)b->serial, sizeof b->serial);
        libusb_close(h);
    }
    if (!b->serial[0])
        snprintf(b->serial, sizeof b->serial, "?");
}

int wdr_transport_list_usb(wdr_usb_board *out, int max, char *err, int errlen)
{
    libusb_context *ctx;
    int rc = libusb_init(&ctx);
    if (rc != 0) {
        snprintf(err, (size_t)errlen, "cannot start libusb: %s", libusb_strerror(rc));
        return WDR_E_IO;
    }
    libusb_device **list;
    ssize_t n = libusb_get_device_list(ctx, &list);
    int found = 0;
    for (ssize_t i = 0; i < n && found < max; i++) {
        int iface;
        uint8_t ep_in, ep_out;
        if (is_wdrcam(list[i], &iface, &ep_in, &ep_out))
            describe(list[i], &out[found++]);
    }
    if (n >= 0)
        libusb_free_device_list(list, 1);
    libusb_exit(ctx);
    if (n < 0) {
        snprintf(err, (size_t)errlen, "cannot list USB devices: %s", libusb_strerror((int)n));
        return WDR_E_IO;
    }
    return found;
}
