/* Transport front: address parsing, argument checks and the deadline helpers shared by the
 * socket and USB backends. */
#include "transport.h"
#include "wdr_err.h"
#include <stdio.h>
#include <string.h>
#include <time.h>

int64_t wdr_transport_now_ms(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (int64_t)ts.tv_sec * 1000 + ts.tv_nsec / 1000000;
}

int wdr_transport_open(const char *address, wdr_transport **out, char *err, int errlen)
{
    return wdr_transport_open_within(address, WDR_TRANSPORT_CONNECT_MS, out, err, errlen);
}

int wdr_transport_open_within(const char *address, int timeout_ms, wdr_transport **out, char *err, int errlen)
{
    *out = NULL;
    if (!address || !*address) {
        snprintf(err, (size_t)errlen, "no device given: use --device sim:/path.sock, usb[:BUS-ADDR], serial:/dev/tty[@BAUD], "
                                      "unix:/path or tcp:HOST:PORT, or set WDR_DEVICE");
        return WDR_E_INVAL;
    }
    if (!strncmp(address, "sim:", 4))
        return wdr_transport_open_socket(address + 4, timeout_ms, out, err, errlen);
    if (!strcmp(address, "usb"))
        return wdr_transport_open_usb(NULL, out, err, errlen);
    if (!strncmp(address, "usb:", 4))
        return wdr_transport_open_usb(address + 4, out, err, errlen);
    if (!strncmp(address, "serial:", 7))
        return wdr_transport_open_serial(address + 7, out, err, errlen);
    if (!strncmp(address, "unix:", 5))
        return wdr_transport_open_unix(address + 5, timeout_ms, out, err, errlen);
    if (!strncmp(address, "tcp:", 4))
        return wdr_transport_open_tcp(address + 4, timeout_ms, out, err, errlen);
    snprintf(err, (size_t)errlen,
             "bad device address '%s': expected sim:/path.sock, usb[:BUS-ADDR], serial:/dev/tty[@BAUD], "
             "unix:/path or tcp:HOST:PORT", address);
    return WDR_E_INVAL;
}

int wdr_transport_send(wdr_transport *t, const void *buf, size_t len, int timeout_ms)
{
    if (!t || (!buf && len))
        return WDR_E_INVAL;
    if (len == 0)
        return WDR_OK;
    return t->ops->send(t, buf, len, timeout_ms < 0 ? 0 : timeout_ms);
}

int wdr_transport_recv(wdr_transport *t, void *buf, size_t cap, int timeout_ms)
{
    if (!t || !buf || cap == 0)
        return WDR_E_INVAL;
    return t->ops->recv(t, buf, cap, timeout_ms < 0 ? 0 : timeout_ms);
}

int wdr_transport_recv_exact(wdr_transport *t, void *buf, size_t len, int timeout_ms)
{
    int64_t deadline = wdr_transport_now_ms() + timeout_ms;
    size_t got = 0;
    while (got < len) {
        int64_t left = deadline - wdr_transport_now_ms();
        int n = wdr_transport_recv(t, (uint8_t *)buf + got, len - got, left < 0 ? 0 : (int)left);
        if (n < 0)
            return n;
        got += (size_t)n;
    }
    return WDR_OK;
}

void wdr_transport_close(wdr_transport *t)
{
    if (t)
        t->ops->close(t);
}

const char *wdr_transport_name(const wdr_transport *t) { return t ? t->name : "(none)"; }

const char *wdr_transport_strerror(int err)
{
    switch (err) {
    case WDR_E_ABSENT: return "board absent";
    case WDR_E_DENIED: return "permission denied";
    case WDR_E_IO: return "board disconnected or I/O error";
    default: return wdr_strerror(err);
    }
}
