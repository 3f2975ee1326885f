/* connect() with a deadline, for the socket backends (unix:, sim:, tcp:). A blocking connect to a
 * listener whose queue is full waits forever on AF_UNIX (the simulated board serves one host
 * and leaves the others queued) and for the kernel's SYN retries on TCP (minutes). */
#include "transport.h"
#include <errno.h>
#include <fcntl.h>
#include <poll.h>
#include <sys/socket.h>
#include <time.h>

static void nap_ms(int ms)
{
    struct timespec ts = {0, (long)ms * 1000000L};
    nanosleep(&ts, NULL);
}

/* A TCP connect in progress: wait for it to finish before the deadline. */
static int finish_connect(int fd, int64_t deadline)
{
    for (;;) {
        struct pollfd p = {.fd = fd, .events = POLLOUT};
        int64_t left = deadline - wdr_transport_now_ms();
        int r = poll(&p, 1, left < 0 ? 0 : (int)left);
        if (r == 0)
            return ETIMEDOUT;
        if (r < 0 && errno == EINTR)
            continue;
        if (r < 0)
            return errno;
        int e = 0;
        socklen_t len = sizeof e;
        if (getsockopt(fd, SOL_SOCKET, SO_ERROR, &e, &len) < 0)
            return errno;
        return e;
    }
}

int wdr_socket_connect(int fd, const void *addr, unsigned addr_len, int timeout_ms)
{
    int flags = fcntl(fd, F_GETFL);
    if (flags < 0 || fcntl(fd, F_SETFL, flags | O_NONBLOCK) < 0)
        return errno;
    int64_t deadline = wdr_transport_now_ms() + (timeout_ms > 0 ? timeout_ms : 0);
    for (;;) {
        if (connect(fd, (const struct sockaddr *)addr, (socklen_t)addr_len) == 0)
            return 0;
        if (errno == EINTR)
            continue;
        if (errno == EINPROGRESS)
            return finish_connect(fd, deadline);
        if (errno != EAGAIN)
            return errno;
        /* AF_UNIX with a full listen queue: nothing wakes us when a place frees, so look again */
        if (wdr_transport_now_ms() >= deadline)
            return ETIMEDOUT;
        nap_ms(10);
    }
}
