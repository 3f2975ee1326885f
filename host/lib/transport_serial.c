/* Byte-stream backends: a serial port (boards that enumerate as a tty, termios raw mode) and a
 * stream socket to an emulated board's UART (QEMU `-serial unix:PATH,server` or
 * `-serial tcp::PORT,server`). The protocol bytes go as they are (firmware/SPEC.md); the
 * decoder on each side resynchronises on its own, so nothing here frames or retries. */
#include "transport.h"
#include "wdr_err.h"
#include <errno.h>
#include <fcntl.h>
#include <netdb.h>
#include <poll.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <termios.h>
#include <unistd.h>

typedef struct tty_transport {
    wdr_transport base; /* first: the public handle points here */
    int fd;
} tty_transport;

static int tty_fd(wdr_transport *t)
{
    return ((tty_transport *)t)->fd;
}

/* Wait until fd is ready for events before deadline; WDR_OK, WDR_E_TIMEOUT or WDR_E_IO. */
static int tty_wait(int fd, short events, int64_t deadline)
{
    for (;;) {
        struct pollfd p = {.fd = fd, .events = events};
        int64_t left = deadline - wdr_transport_now_ms();
        int r = poll(&p, 1, left < 0 ? 0 : (int)left);
        if (r > 0)
            return (p.revents & events) ? WDR_OK : WDR_E_IO; /* POLLHUP/POLLERR alone: unplugged */
        if (r == 0)
            return WDR_E_TIMEOUT;
        if (errno != EINTR)
            return WDR_E_IO;
    }
}

static int tty_send(wdr_transport *t, const uint8_t *buf, size_t len, int timeout_ms)
{
    int64_t deadline = wdr_transport_now_ms() + timeout_ms;
    size_t done = 0;
    while (done < len) {
        int rc = tty_wait(tty_fd(t), POLLOUT, deadline);
        if (rc != WDR_OK)
            return rc;
        ssize_t n = write(tty_fd(t), buf + done, len - done);
        if (n < 0 && (errno == EAGAIN || errno == EINTR))
            continue;
        if (n <= 0)
            return WDR_E_IO;
        done += (size_t)n;
    }
    return WDR_OK;
}

static int tty_recv(wdr_transport *t, uint8_t *buf, size_t cap, int timeout_ms)
{
    int64_t deadline = wdr_transport_now_ms() + timeout_ms;
    for (;;) {
        int rc = tty_wait(tty_fd(t), POLLIN, deadline);
        if (rc != WDR_OK)
            return rc;
        ssize_t n = read(tty_fd(t), buf, cap > 0x7fffffff ? 0x7fffffff : cap);
        if (n > 0)
            return (int)n;
        if (n == 0)
            return WDR_E_IO; /* the port went away */
        if (errno != EAGAIN && errno != EINTR)
            return WDR_E_IO;
    }
}

static void tty_close(wdr_transport *t)
{
    close(tty_fd(t));
    free(t);
}

static const wdr_transport_ops tty_ops = {tty_send, tty_recv, tty_close};

static speed_t baud_code(long baud)
{
    static const struct {
        long baud;
        speed_t code;
    } rates[] = {{9600, B9600},       {19200, B19200},     {38400, B38400},     {57600, B57600},
                 {115200, B115200},   {230400, B230400},   {460800, B460800},   {921600, B921600},
                 {1000000, B1000000}, {2000000, B2000000}, {3000000, B3000000}, {4000000, B4000000}};
    for (size_t i = 0; i < sizeof rates / sizeof rates[0]; i++)
        if (rates[i].baud == baud)
            return rates[i].code;
    return 0;
}

/* Raw 8N1, no flow control, no echo, no line discipline: the protocol's bytes as they are. */
static int tty_raw(int fd, speed_t speed, const char *path, char *err, int errlen)
{
    struct termios tio;
    if (tcgetattr(fd, &tio) < 0) {
        snprintf(err, (size_t)errlen, "%s is not a serial port: %s", path, strerror(errno));
        return WDR_E_INVAL;
    }
    cfmakeraw(&tio);
    tio.c_cflag |= CLOCAL | CREAD;
    tio.c_cflag &= ~(tcflag_t)(CRTSCTS | CSTOPB);
    tio.c_cc[VMIN] = 0;
    tio.c_cc[VTIME] = 0;
    if (cfsetispeed(&tio, speed) < 0 || cfsetospeed(&tio, speed) < 0 || tcsetattr(fd, TCSANOW, &tio) < 0) {
        snprintf(err, (size_t)errlen, "%s: cannot set raw mode: %s", path, strerror(errno));
        return WDR_E_IO;
    }
    tcflush(fd, TCIOFLUSH); /* stale bytes from before: the decoder would resynchronise, but why wait */
    return WDR_OK;
}

/* "PATH" or "PATH@BAUD" (default 115200). */
int wdr_transport_open_serial(const char *spec, wdr_transport **out, char *err, int errlen)
{
    char path[128];
    long baud = 115200;
    const char *at = strrchr(spec, '@');
    size_t plen = at ? (size_t)(at - spec) : strlen(spec);
    *out = NULL;
    if (at) {
        char *end;
        baud = strtol(at + 1, &end, 10);
        if (end == at + 1 || *end || !baud_code(baud)) {
            snprintf(err, (size_t)errlen, "serial:%s: baud rate '%s' is not one of 9600..4000000", spec, at + 1);
            return WDR_E_INVAL;
        }
    }
    if (plen == 0 || plen >= sizeof path) {
        snprintf(err, (size_t)errlen, "serial:%s: expected serial:/dev/ttyXXX[@BAUD]", spec);
        return WDR_E_INVAL;
    }
    memcpy(path, spec, plen);
    path[plen] = 0;
    int fd = open(path, O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
    if (fd < 0) {
        int e = errno;
        snprintf(err, (size_t)errlen, "cannot open serial port %s: %s%s", path, strerror(e),
                 e == EACCES ? " (is your user in the dialout group?)" : "");
        return e == ENOENT ? WDR_E_ABSENT : e == EACCES || e == EPERM ? WDR_E_DENIED : WDR_E_IO;
    }
    int rc = tty_raw(fd, baud_code(baud), path, err, errlen);
    tty_transport *s = rc ? NULL : calloc(1, sizeof *s);
    if (!s) {
        close(fd);
        return rc ? rc : WDR_E_NOMEM;
    }
    s->base.ops = &tty_ops;
    s->fd = fd;
    snprintf(s->base.name, sizeof s->base.name, "serial:%s", spec);
    *out = &s->base;
    return WDR_OK;
}

/* ---- sockets to an emulated UART ---- */

static int wrap_socket(int fd, const char *name, wdr_transport **out)
{
    int rc = wdr_transport_from_fd(fd, name, out);
    if (rc != WDR_OK)
        close(fd);
    return rc;
}

static int socket_error(const char *what, const char *addr, int e, int timeout_ms, char *err, int errlen)
{
    if (e == ETIMEDOUT) {
        snprintf(err, (size_t)errlen, "the board at %s:%s accepted no connection within %d ms (its queue is full, "
                 "or nothing answers there)", what, addr, timeout_ms);
        return WDR_E_TIMEOUT;
    }
    snprintf(err, (size_t)errlen, "no board at %s:%s (%s): is the emulator running with -serial %s:%s,server?", what,
             addr, strerror(e), what, addr);
    return e == ENOENT || e == ECONNREFUSED ? WDR_E_ABSENT : e == EACCES ? WDR_E_DENIED : WDR_E_IO;
}

int wdr_transport_open_unix(const char *path, int timeout_ms, wdr_transport **out, char *err, int errlen)
{
    struct sockaddr_un sa = {.sun_family = AF_UNIX};
    *out = NULL;
    if (!*path || strlen(path) >= sizeof sa.sun_path) {
        snprintf(err, (size_t)errlen, "bad socket path '%s': empty or longer than %zu bytes", path,
                 sizeof sa.sun_path - 1);
        return WDR_E_INVAL;
    }
    memcpy(sa.sun_path, path, strlen(path) + 1);
    int fd = socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
    int e = fd < 0 ? errno : wdr_socket_connect(fd, &sa, sizeof sa, timeout_ms);
    if (e) {
        if (fd >= 0)
            close(fd);
        return socket_error("unix", path, e, timeout_ms, err, errlen);
    }
    char name[160];
    snprintf(name, sizeof name, "unix:%s", path);
    return wrap_socket(fd, name, out);
}

/* "HOST:PORT" */
int wdr_transport_open_tcp(const char *spec, int timeout_ms, wdr_transport **out, char *err, int errlen)
{
    char host[128];
    const char *colon = strrchr(spec, ':');
    *out = NULL;
    if (!colon || colon == spec || !colon[1] || (size_t)(colon - spec) >= sizeof host) {
        snprintf(err, (size_t)errlen, "bad address 'tcp:%s': expected tcp:HOST:PORT", spec);
        return WDR_E_INVAL;
    }
    memcpy(host, spec, (size_t)(colon - spec));
    host[colon - spec] = 0;
    struct addrinfo hints = {.ai_family = AF_UNSPEC, .ai_socktype = SOCK_STREAM}, *ai;
    int g = getaddrinfo(host, colon + 1, &hints, &ai);
    if (g) {
        snprintf(err, (size_t)errlen, "tcp:%s: %s", spec, gai_strerror(g));
        return WDR_E_INVAL;
    }
    int fd = -1, e = ECONNREFUSED;
    int64_t deadline = wdr_transport_now_ms() + timeout_ms; /* one deadline for all the addresses */
    for (struct addrinfo *a = ai; a && fd < 0; a = a->ai_next) {
        fd = socket(a->ai_family, a->ai_socktype | SOCK_CLOEXEC, a->ai_protocol);
        int64_t left = deadline - wdr_transport_now_ms();
        if (fd >= 0 && (e = wdr_socket_connect(fd, a->ai_addr, a->ai_addrlen, left < 0 ? 0 : (int)left)) != 0) {
            close(fd);
            fd = -1;
        }
    }
    freeaddrinfo(ai);
    if (fd < 0)
        return socket_error("tcp", spec, e, timeout_ms, err, errlen);
    char name[160];
    snprintf(name, sizeof name, "tcp:%s", spec);
    return wrap_socket(fd, name, out);
}
