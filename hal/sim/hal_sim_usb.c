/* Simulated board, USB: the bulk endpoints carried over an AF_UNIX stream socket. The bytes
 * are the protocol's, as-is (firmware/SPEC.md): what a real board's bulk OUT receives arrives
 * here, what its bulk IN sends leaves here. One host at a time, like a USB port; a second
 * connection waits in the listen queue until the first host leaves. */
#include "hal_sim_internal.h"
#include <errno.h>
#include <fcntl.h>
#include <poll.h>
#include <stdatomic.h>
#include <stdio.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#define USB_MAX_TRANSFER 65536u

static struct {
    int listen_fd, client_fd;
    char path[sizeof(((struct sockaddr_un *)0)->sun_path)];
    int rx_armed;         /* post USB_RX on the next readable socket (re-armed by each read) */
    const uint8_t *tx;    /* transfer in flight, or NULL */
    size_t tx_len, tx_done;
    uint64_t tx_total;    /* bytes sent since setup */
    uint64_t corrupt_at;  /* tx_total + 1 of the byte to flip, 0: none */
} U = {.listen_fd = -1, .client_fd = -1};

/* Faults armed from other threads; the serving thread applies them. */
static atomic_uint drop_rx_left, corrupt_tx_k;
static atomic_int unplug_requested;

static void set_nonblocking(int fd) { fcntl(fd, F_SETFL, fcntl(fd, F_GETFL) | O_NONBLOCK); }

/* ---- Connection life ------------------------------------------------------------------- */

static void drop_client(int post_events)
{
    if (U.client_fd < 0)
        return;
    close(U.client_fd);
    U.client_fd = -1;
    if (U.tx && post_events)
        hal_sim_post(HAL_EV_USB_TX_DONE, 0); /* the buffer is the firmware's again */
    U.tx = NULL;
    if (post_events) {
        hal_sim_post(HAL_EV_USB_RESET, 0);
        if (hal_sim_exit_on_disconnect)
            hal_sim_request_stop();
    }
}

static void accept_client(void)
{
    int fd = accept(U.listen_fd, NULL, NULL);
    if (fd < 0)
        return;
    set_nonblocking(fd);
    U.client_fd = fd;
    U.rx_armed = 1;
    hal_sim_post(HAL_EV_USB_RESET, 0); /* a host attached: start from a clean decoder */
}

int hal_sim_usb_setup(const char *path, char *err, int errlen)
{
    struct sockaddr_un sa = {.sun_family = AF_UNIX};
    struct stat st;
    if (!*path || strlen(path) >= sizeof sa.sun_path) {
        snprintf(err, (size_t)errlen, "socket path '%s' is empty or longer than %zu bytes", path, sizeof sa.sun_path - 1);
        return WDR_E_INVAL;
    }
    if (lstat(path, &st) == 0 && S_ISSOCK(st.st_mode))
        unlink(path); /* a stale socket of an earlier run; never remove anything else */
    memcpy(sa.sun_path, path, strlen(path) + 1);
    U.listen_fd = socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
    if (U.listen_fd < 0 || bind(U.listen_fd, (struct sockaddr *)&sa, sizeof sa) < 0 || listen(U.listen_fd, 4) < 0) {
        snprintf(err, (size_t)errlen, "cannot listen on socket %s: %s", path, strerror(errno));
        if (U.listen_fd >= 0)
            close(U.listen_fd);
        U.listen_fd = -1;
        return WDR_E_IO;
    }
    set_nonblocking(U.listen_fd);
    memcpy(U.path, path, strlen(path) + 1);
    return WDR_OK;
}

void hal_sim_usb_teardown(void)
{
    drop_client(0);
    if (U.listen_fd >= 0) {
        close(U.listen_fd);
        unlink(U.path);
    }
    U.listen_fd = -1;
    U.path[0] = 0;
    U.tx_total = U.corrupt_at = 0;
    atomic_store(&drop_rx_left, 0);
    atomic_store(&corrupt_tx_k, 0);
    atomic_store(&unplug_requested, 0);
}

/* A reset cuts the bus: the host sees the board go away and must reconnect. */
void hal_sim_usb_reboot(void) { drop_client(0); }

int hal_sim_usb_tx_pending(void) { return U.tx != NULL; }

/* ---- Moving bytes ------------------------------------------------------------------------ */

/* How many bytes to send next, and the byte to use if the first of them is the flipped one. */
static size_t next_span(const uint8_t **p, uint8_t *flipped)
{
    unsigned k = atomic_exchange(&corrupt_tx_k, 0);
    if (k)
        U.corrupt_at = U.tx_total + k;
    size_t n = U.tx_len - U.tx_done;
    *p = U.tx + U.tx_done;
    if (!U.corrupt_at || U.corrupt_at > U.tx_total + n)
        return n;
    if (U.corrupt_at > U.tx_total + 1)
        return (size_t)(U.corrupt_at - U.tx_total - 1); /* up to the byte before it */
    *flipped = (uint8_t)(**p ^ 0xFFu);
    *p = flipped;
    return 1;
}

static void continue_tx(void)
{
    while (U.tx && U.tx_done < U.tx_len) {
        const uint8_t *p;
        uint8_t flipped;
        size_t span = next_span(&p, &flipped);
        ssize_t n = send(U.client_fd, p, span, MSG_NOSIGNAL | MSG_DONTWAIT);
        if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK))
            return;
        if (n < 0 && errno == EINTR)
            continue;
        if (n <= 0) {
            drop_client(1);
            return;
        }
        if (p == &flipped)
            U.corrupt_at = 0;
        U.tx_done += (size_t)n;
        U.tx_total += (uint64_t)n;
    }
    if (U.tx) {
        U.tx = NULL;
        hal_sim_post(HAL_EV_USB_TX_DONE, 0);
    }
}

static int build_pollset(struct pollfd *p)
{
    int n = 0;
    if (U.listen_fd >= 0 && U.client_fd < 0)
        p[n++] = (struct pollfd){.fd = U.listen_fd, .events = POLLIN};
    if (U.client_fd >= 0)
        p[n++] = (struct pollfd){.fd = U.client_fd, .events = (short)((U.rx_armed ? POLLIN : 0) | (U.tx ? POLLOUT : 0))};
    if (hal_sim_eof_fd >= 0)
        p[n++] = (struct pollfd){.fd = hal_sim_eof_fd, .events = POLLIN};
    return n;
}

static void handle_eof_fd(void)
{
    char sink[256];
    ssize_t n = read(hal_sim_eof_fd, sink, sizeof sink);
    if (n == 0 || (n < 0 && errno != EAGAIN && errno != EINTR)) {
        hal_sim_eof_fd = -1;
        hal_sim_request_stop();
    }
}

static void handle_client(short revents)
{
    if (revents & POLLOUT)
        continue_tx();
    if (U.client_fd < 0)
        return;
    if (U.rx_armed && (revents & (POLLIN | POLLHUP | POLLERR))) {
        U.rx_armed = 0;
        hal_sim_post(HAL_EV_USB_RX, 0); /* the firmware's read meets the data, or the EOF */
    } else if (revents & (POLLHUP | POLLERR)) {
        drop_client(1); /* gone while the firmware was not reading */
    }
}

void hal_sim_usb_pump(int timeout_ms)
{
    if (atomic_exchange(&unplug_requested, 0))
        drop_client(1);
    struct pollfd p[3];
    int n = build_pollset(p);
    if (poll(p, (nfds_t)n, timeout_ms) <= 0)
        return;
    for (int i = 0; i < n; i++) {
        if (!p[i].revents)
            continue;
        if (p[i].fd == U.listen_fd)
            accept_client();
        else if (p[i].fd == U.client_fd)
            handle_client(p[i].revents);
        else if (p[i].fd == hal_sim_eof_fd)
            handle_eof_fd();
    }
}

/* ---- The HAL functions ------------------------------------------------------------------- */

/* Lose armed bytes from the front of what was just received; returns what is left. */
static size_t drop_injected(uint8_t *buf, size_t n)
{
    unsigned left = atomic_load(&drop_rx_left);
    size_t drop = left < n ? left : n;
    if (!drop)
        return n;
    atomic_fetch_sub(&drop_rx_left, (unsigned)drop);
    memmove(buf, buf + drop, n - drop);
    return n - drop;
}

size_t hal_usb_max_transfer(void) { return USB_MAX_TRANSFER; }

int hal_usb_read(uint8_t *buf, size_t cap)
{
    U.rx_armed = 1;
    if (U.client_fd < 0)
        return WDR_E_IO;
    if (cap == 0)
        return 0;
    for (;;) {
        ssize_t n = recv(U.client_fd, buf, cap, MSG_DONTWAIT);
        if (n > 0)
            return (int)drop_injected(buf, (size_t)n);
        if (n < 0 && errno == EINTR)
            continue;
        if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK))
            return 0;
        drop_client(1);
        return WDR_E_IO;
    }
}

int hal_usb_write(const uint8_t *buf, size_t len)
{
    if (U.client_fd < 0)
        return WDR_E_IO;
    if (U.tx)
        return WDR_E_BUSY;
    if (len > USB_MAX_TRANSFER)
        return WDR_E_TOO_LARGE;
    if (!buf && len)
        return WDR_E_INVAL;
    U.tx = buf ? buf : (const uint8_t *)"";
    U.tx_len = len;
    U.tx_done = 0;
    continue_tx();
    return WDR_OK;
}

/* ---- Fault injection ------------------------------------------------------------------------ */

void hal_sim_usb_drop_rx(uint32_t n) { atomic_store(&drop_rx_left, n); }

void hal_sim_usb_corrupt_tx(uint32_t k) { atomic_store(&corrupt_tx_k, k); }

void hal_sim_usb_unplug(void) { atomic_store(&unplug_requested, 1); }
