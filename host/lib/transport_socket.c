/* Socket backend: an AF_UNIX stream to wdr-simboard, or any connected stream (tests).
 * Waits are poll() with the caller's timeout; sends never raise SIGPIPE. */
#include "transport.h"
#include "wdr_err.h"
#include <errno.h>
#include <poll.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

typedef struct socket_transport {
    wdr_transport base; /* first: the public handle points here */
    int fd;
} socket_transport;

static int socket_fd(wdr_transport *t) { return ((socket_transport *)t)->fd; }

/* Wait until fd is ready for `events`; WDR_OK, WDR_E_TIMEOUT or WDR_E_IO. */
static int wait_ready(int fd, short events, int timeout_ms)
{
    int64_t deadline = wdr_transport_now_ms() + timeout_ms;
    for (;;) {
        struct pollfd p = {.fd = fd, .events = events};
        int64_t left = deadline - wdr_transport_now_ms();
        int r = poll(&p, 1, left < 0 ? 0 : (int)left);
        if (r > 0)
            return (p.revents & (events | POLLHUP | POLLERR)) ? WDR_OK : WDR_E_IO;
        if (r == 0)
            return WDR_E_TIMEOUT;
        if (errno != EINTR)
            return WDR_E_IO;
    }
}

static int socket_send(wdr_transport *t, const uint8_t *buf, size_t len, int timeout_ms)
{
    int64_t deadline = wdr_transport_now_ms() + timeout_ms;
    size_t done = 0;
    while (done < len) {
        int64_t left = deadline - wdr_transport_now_ms();
        int rc = wait_ready(socket_fd(t), POLLOUT, left < 0 ? 0 : (int)left);
        if (rc != WDR_OK)
            return rc;
        ssize_t n = send(socket_fd(t), buf + done, len - done, MSG_NOSIGNAL | MSG_DONTWAIT);
        if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR))
            continue;
        if (n <= 0)
            return WDR_E_IO;
        done += (size_t)n;
    }
    return WDR_OK;
}

static int socket_recv(wdr_transport *t, uint8_t *buf, size_t cap, int timeout_ms)
{
    int64_t deadline = wdr_transport_now_ms() + timeout_ms;
    for (;;) {
        int64_t left = deadline - wdr_transport_now_ms();
        int rc = wait_ready(socket_fd(t), POLLIN, left < 0 ? 0 : (int)left);
        if (rc != WDR_OK)
            return rc;
        ssize_t n = recv(socket_fd(t), buf, cap, MSG_DONTWAIT);
        if (n > 0)
            return (int)(n > 0x7fffffff ? 0x7fffffff : n);
        if (n == 0)
            return WDR_E_IO; /* orderly close: the board went away */
        if (errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR)
            return WDR_E_IO;
    }
}

static void socket_close(wdr_transport *t)
{
    close(socket_fd(t));
    free(t);
}

static const wdr_transport_ops socket_ops = {socket_send, socket_recv, socket_close};

int wdr_transport_from_fd(int fd, const char *name, wdr_transport **out)
{
    *out = NULL;
    if (fd < 0)
        return WDR_E_INVAL;
    socket_transport *s = calloc(1, sizeof *s);
    if (!s)
        return WDR_E_NOMEM;
    s->base.ops = &socket_ops;
    s->fd = fd;
    snprintf(s->base.name, sizeof s->base.name, "%s", name ? name : "socket");
    *out = &s->base;
    return WDR_OK;
}

static int connect_error(const char *path, int e, int timeout_ms, char *err, int errlen)
{
    if (e == ETIMEDOUT) {
        snprintf(err, (size_t)errlen, "the simulated board at %s accepted no connection within %d ms (its queue is "
                 "full: another host holds it)", path, timeout_ms);
        return WDR_E_TIMEOUT;
    }
    if (e == ENOENT || e == ECONNREFUSED || e == ENOTSOCK) {
        snprintf(err, (size_t)errlen, "no simulated board at %s (%s): is wdr-simboard running with --socket %s?",
                 path, strerror(e), path);
        return WDR_E_ABSENT;
    }
    snprintf(err, (size_t)errlen, "cannot connect to simulated board at %s: %s", path, strerror(e));
    return e == EACCES || e == EPERM ? WDR_E_DENIED : WDR_E_IO;
}

int wdr_transport_open_socket(const char *path, int timeout_ms, wdr_transport **out, char *err, int errlen)
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
    if (fd < 0) {
        snprintf(err, (size_t)errlen, "socket(): %s", strerror(errno));
        return WDR_E_IO;
    }
    int e = wdr_socket_connect(fd, &sa, sizeof sa, timeout_ms);
    if (e) {
        close(fd);
        return connect_error(path, e, timeout_ms, err, errlen);
    }
    char name[160];
    snprintf(name, sizeof name, "sim:%s", path);
    int rc = wdr_transport_from_fd(fd, name, out);
    if (rc != WDR_OK)
        close(fd);
    return rc;
}
