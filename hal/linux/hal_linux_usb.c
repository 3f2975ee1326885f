/* Real board on embedded Linux, USB: one vendor interface with a bulk IN and a bulk OUT
 * endpoint, served through FunctionFS (the gadget is assembled in configfs, see README.md).
 * Three threads stand in for the USB interrupts: ep0 events, OUT reads and IN writes; they
 * only move bytes and post events, the firmware's task loop does the rest.
 *
 * Bulk IN is double-buffered: hal_usb_write copies the firmware's frame into the filling
 * buffer and hands the buffer back at once, while the IN thread sends the other one. Frames
 * queued meanwhile leave as one transfer, which a USB host takes in far fewer transactions
 * than one per frame (one row of a VGA frame is 1.3 KB). */
#include "hal_linux_internal.h"
#include <errno.h>
#include <fcntl.h>
#include <linux/aio_abi.h>
#include <linux/usb/functionfs.h>
#include <pthread.h>
#include <signal.h>
#include <stdatomic.h>
#include <stdio.h>
#include <string.h>
#include <sys/ioctl.h>
#include <sys/syscall.h>
#include <time.h>
#include <unistd.h>

#define RX_RING 65536u    /* power of two */
#define MAX_TRANSFER 65536u
#define FS_PACKET 64u
#define HS_PACKET 512u
#define SS_PACKET 1024u

static struct {
    pthread_mutex_t lock;
    pthread_cond_t cond;
    int ep0, ep_in, ep_out;
    int connected;
    uint16_t in_packet, out_packet; /* max packet sizes at the speed of the current link */
    uint8_t ring[RX_RING];
    uint32_t r_head, r_tail; /* free-running; fill = head - tail */
    uint8_t tx[2][MAX_TRANSFER];
    size_t tx_fill; /* bytes waiting in tx[tx_filling] */
    int tx_filling;
    int tx_refused; /* hal_usb_write said BUSY: tell the firmware when there is room */
    int tx_busy;    /* the IN thread is writing a transfer it took (lx_usb_close waits for it) */
    pthread_t threads[3]; /* ep0, OUT, IN */
    atomic_int ended[3]; /* set by a thread as it returns: lx_usb_close joins it then */
    int n_threads;
    atomic_int stopping; /* lx_usb_close: the ep0 and IN threads return at their next wake */
} U = {.lock = PTHREAD_MUTEX_INITIALIZER, .cond = PTHREAD_COND_INITIALIZER, .ep0 = -1, .ep_in = -1, .ep_out = -1,
       .in_packet = HS_PACKET, .out_packet = HS_PACKET};

/* ---- Descriptors -------------------------------------------------------------------------- */

/* FunctionFS wants little-endian fields; glibc's htole32 is not a constant expression. */
#if !defined(__BYTE_ORDER__) || __BYTE_ORDER__ != __ORDER_LITTLE_ENDIAN__
#error "descriptor tables below are written for little-endian targets"
#endif
#define LE(x) (x)

struct ep_pair {
    struct usb_interface_descriptor intf;
    struct usb_endpoint_descriptor_no_audio in, out;
} __attribute__((packed));

/* SuperSpeed endpoints each need a companion descriptor (no bursts, no streams). */
struct ss_ep {
    struct usb_endpoint_descriptor_no_audio ep;
    struct usb_ss_ep_comp_descriptor comp;
} __attribute__((packed));

struct ss_set {
    struct usb_interface_descriptor intf;
    struct ss_ep in, out;
} __attribute__((packed));

static const struct {
    struct usb_functionfs_descs_head_v2 head;
    __le32 fs_count, hs_count, ss_count;
    struct ep_pair fs, hs;
    struct ss_set ss;
} __attribute__((packed)) descriptors = {
    .head = {.magic = LE(FUNCTIONFS_DESCRIPTORS_MAGIC_V2),
             .length = LE(sizeof descriptors),
             .flags = LE(FUNCTIONFS_HAS_FS_DESC | FUNCTIONFS_HAS_HS_DESC | FUNCTIONFS_HAS_SS_DESC)},
    .fs_count = LE(3),
    .hs_count = LE(3),
    .ss_count = LE(5),
#define WDR_INTF                                                                                                     \
    {.bLength = sizeof(struct usb_interface_descriptor), .bDescriptorType = USB_DT_INTERFACE, .bNumEndpoints = 2,   \
     .bInterfaceClass = 0xff, .bInterfaceSubClass = 0x57, .bInterfaceProtocol = 0x01, .iInterface = 1}
#define WDR_EP(addr, size)                                                                                           \
    {.bLength = USB_DT_ENDPOINT_SIZE, .bDescriptorType = USB_DT_ENDPOINT, .bEndpointAddress = (addr),               \
     .bmAttributes = USB_ENDPOINT_XFER_BULK, .wMaxPacketSize = LE(size)}
    .fs = {WDR_INTF, WDR_EP(1 | USB_DIR_IN, FS_PACKET), WDR_EP(2 | USB_DIR_OUT, FS_PACKET)},
    .hs = {WDR_INTF, WDR_EP(1 | USB_DIR_IN, HS_PACKET), WDR_EP(2 | USB_DIR_OUT, HS_PACKET)},
#define WDR_SS_COMP {.bLength = USB_DT_SS_EP_COMP_SIZE, .bDescriptorType = USB_DT_SS_ENDPOINT_COMP}
    .ss = {WDR_INTF, {WDR_EP(1 | USB_DIR_IN, SS_PACKET), WDR_SS_COMP}, {WDR_EP(2 | USB_DIR_OUT, SS_PACKET), WDR_SS_COMP}},
};

#define STR_INTERFACE "wdrcam"
static const struct {
    struct usb_functionfs_strings_head head;
    struct {
        __le16 code;
        char str[sizeof STR_INTERFACE];
    } __attribute__((packed)) lang0;
} __attribute__((packed)) strings = {
    .head = {.magic = LE(FUNCTIONFS_STRINGS_MAGIC), .length = LE(sizeof strings),
             .str_count = LE(1), .lang_count = LE(1)},
    .lang0 = {LE(0x0409), STR_INTERFACE},
};

/* ---- Threads ---------------------------------------------------------------------------------- */

/* FunctionFS errors that say "try again" rather than "the link is gone". */
static int transient(int err) { return err == EINTR || err == EAGAIN; }

/* The endpoint's wMaxPacketSize at the speed the host enumerated us; fallback if unknown. */
static uint16_t packet_size(int fd, uint16_t fallback)
{
    struct usb_endpoint_descriptor d;
    if (ioctl(fd, FUNCTIONFS_ENDPOINT_DESC, &d) < 0 || d.wMaxPacketSize == 0)
        return fallback;
    return (uint16_t)(d.wMaxPacketSize & 0x7ffu);
}

static void set_connected(int on)
{
    uint16_t in = on ? packet_size(U.ep_in, HS_PACKET) : HS_PACKET;
    uint16_t out = on ? packet_size(U.ep_out, HS_PACKET) : HS_PACKET;
    pthread_mutex_lock(&U.lock);
    U.connected = on;
    U.in_packet = in;
    U.out_packet = out;
    if (!on) {
        U.r_head = U.r_tail = 0; /* a new host starts a new byte stream */
        U.tx_fill = 0;
    }
    pthread_cond_broadcast(&U.cond);
    pthread_mutex_unlock(&U.lock);
    lx_post(HAL_EV_USB_RESET, 0);
}

/* A control request to our interface: we define none, so stall it. FunctionFS stalls when ep0
 * is used against the request's direction: read for an IN request, write for an OUT one. */
static void stall_setup(const struct usb_ctrlrequest *req)
{
    ssize_t r = (req->bRequestType & USB_DIR_IN) ? read(U.ep0, NULL, 0) : write(U.ep0, NULL, 0);
    (void)r; /* -1 with EL2HLT is the stall done */
}

static void on_ep0_event(const struct usb_functionfs_event *ev)
{
    switch (ev->type) {
    case FUNCTIONFS_ENABLE: set_connected(1); break;
    case FUNCTIONFS_DISABLE:
    case FUNCTIONFS_UNBIND: set_connected(0); break;
    case FUNCTIONFS_SUSPEND: /* the host suspended the bus (autosuspend): the configuration and */
    case FUNCTIONFS_RESUME:  /* our session stay; transfers wait in the controller until resume */
        break;
    case FUNCTIONFS_SETUP: stall_setup(&ev->u.setup); break;
    default: break; /* BIND */
    }
}

static void *ep0_main(void *arg)
{
    (void)arg;
    struct usb_functionfs_event ev[4];
    while (!atomic_load(&U.stopping)) {
        ssize_t n = read(U.ep0, ev, sizeof ev);
        if (n < 0 && (transient(errno) || errno == EL2HLT))
            continue; /* EINTR: perhaps lx_usb_close's wake; the loop's test tells */
        if (n <= 0) { /* ep0 closed under us: nothing more will come */
            fprintf(stderr, "wdr-board: read %s/ep0: %s\n", lx_board_get()->functionfs, n ? strerror(errno) : "end of file");
            set_connected(0);
            break;
        }
        for (ssize_t i = 0; i < n / (ssize_t)sizeof ev[0]; i++)
            on_ep0_event(&ev[i]);
    }
    atomic_store(&U.ended[0], 1);
    return NULL;
}

/* Copy a received packet into the ring, waiting for room: the host is NAKed meanwhile. */
static void ring_put(const uint8_t *p, size_t n)
{
    pthread_mutex_lock(&U.lock);
    while (U.connected && RX_RING - (U.r_head - U.r_tail) < n)
        pthread_cond_wait(&U.cond, &U.lock);
    for (size_t i = 0; i < n && U.connected; i++)
        U.ring[U.r_head++ & (RX_RING - 1u)] = p[i];
    pthread_mutex_unlock(&U.lock);
}

/* Until ep0 reports a host (the endpoints are disabled meanwhile). */
static void wait_connected(void)
{
    pthread_mutex_lock(&U.lock);
    while (!U.connected)
        pthread_cond_wait(&U.cond, &U.lock);
    pthread_mutex_unlock(&U.lock);
}

/* Bulk OUT reads one packet per request, so a read never waits for more than arrived (the
 * host sends no zero-length packet after a transfer that fills its last packet). RX_DEPTH
 * such requests stay queued through Linux AIO: the device controller fills them back to
 * back, where one blocking read at a time would take one packet per USB frame. */
#define RX_DEPTH 16u

static uint8_t rx_buf[RX_DEPTH][SS_PACKET];
static struct iocb rx_cb[RX_DEPTH];

static int rx_submit(aio_context_t ctx, unsigned i, size_t want)
{
    struct iocb *cb = &rx_cb[i];
    memset(cb, 0, sizeof *cb);
    cb->aio_fildes = (uint32_t)U.ep_out;
    cb->aio_lio_opcode = IOCB_CMD_PREAD;
    cb->aio_buf = (uint64_t)(uintptr_t)rx_buf[i];
    cb->aio_nbytes = want;
    cb->aio_data = i;
    while (syscall(SYS_io_submit, ctx, 1L, &cb) != 1)
        if (!transient(errno))
            return -1;
    return 0;
}

static size_t out_packet_now(void)
{
    pthread_mutex_lock(&U.lock);
    size_t want = U.out_packet <= SS_PACKET ? U.out_packet : SS_PACKET;
    pthread_mutex_unlock(&U.lock);
    return want;
}

/* Serve one connection: keep RX_DEPTH reads queued until they fail with the link. */
static void rx_serve(aio_context_t ctx)
{
    size_t want = out_packet_now();
    unsigned queued = 0;
    for (unsigned i = 0; i < RX_DEPTH; i++)
        queued += rx_submit(ctx, i, want) == 0;
    while (queued > 0) {
        struct io_event ev[RX_DEPTH];
        long n = syscall(SYS_io_getevents, ctx, 1L, (long)RX_DEPTH, ev, NULL);
        if (n < 0 && transient(errno))
            continue;
        if (n < 0)
            return;
        for (long k = 0; k < n; k++) { /* in completion order, which is the packets' order */
            unsigned i = (unsigned)ev[k].data;
            queued--;
            if (ev[k].res > 0) {
                ring_put(rx_buf[i], (size_t)ev[k].res);
                lx_post(HAL_EV_USB_RX, 0);
            }
            if (ev[k].res >= 0 || -ev[k].res == EINTR || -ev[k].res == EAGAIN)
                queued += rx_submit(ctx, i, want) == 0;
            /* else ESHUTDOWN, ECONNRESET: the link went; ep0 reports it */
        }
    }
}

static void *rx_main(void *arg)
{
    (void)arg;
    aio_context_t ctx = 0;
    if (syscall(SYS_io_setup, RX_DEPTH, &ctx) < 0) {
        fprintf(stderr, "wdr-board: io_setup: %s: bulk OUT stops\n", strerror(errno));
        return NULL;
    }
    for (;;) {
        wait_connected();
        rx_serve(ctx);
        usleep(1000); /* until ep0 has seen the link go */
    }
    return NULL;
}

/* 0 when all was sent; -1 when the link went (the bytes are lost with it). */
static int write_all(const uint8_t *p, size_t len)
{
    while (len > 0) {
        ssize_t n = write(U.ep_in, p, len);
        if (n < 0 && transient(errno) && !atomic_load(&U.stopping))
            continue;
        if (n <= 0)
            return -1;
        p += n;
        len -= (size_t)n;
    }
    return 0;
}

/* Take the filled buffer for sending, handing the other one to hal_usb_write; 0 when
 * lx_usb_close stops the thread. */
static size_t tx_take(const uint8_t **p, uint16_t *packet)
{
    pthread_mutex_lock(&U.lock);
    while (!U.tx_fill && !atomic_load(&U.stopping))
        pthread_cond_wait(&U.cond, &U.lock);
    if (atomic_load(&U.stopping)) {
        pthread_mutex_unlock(&U.lock);
        return 0;
    }
    size_t len = U.tx_fill;
    U.tx_busy = 1;
    *p = U.tx[U.tx_filling];
    *packet = U.in_packet;
    U.tx_filling ^= 1;
    U.tx_fill = 0;
    int refused = U.tx_refused;
    U.tx_refused = 0;
    pthread_mutex_unlock(&U.lock);
    if (refused)
        lx_post(HAL_EV_USB_TX_DONE, 0); /* room again: the firmware retries its frame */
    return len;
}

static void *tx_main(void *arg)
{
    (void)arg;
    for (;;) {
        const uint8_t *p;
        uint16_t packet;
        size_t len = tx_take(&p, &packet);
        if (len == 0)
            break;
        /* A transfer that fills its last packet needs a zero-length packet to end it; the
         * packet is the endpoint's at this link's speed (64, 512 or 1024 bytes). */
        if (write_all(p, len) == 0 && len % packet == 0 && write(U.ep_in, p, 0) < 0) {
            /* the host went away: ep0 reports the reset */
        }
        pthread_mutex_lock(&U.lock);
        U.tx_busy = 0;
        pthread_cond_broadcast(&U.cond); /* lx_usb_close may be waiting for this transfer */
        pthread_mutex_unlock(&U.lock);
    }
    atomic_store(&U.ended[2], 1);
    return NULL;
}

/* ---- Init and the HAL functions ---------------------------------------------------------------- */

static int open_ep(const char *name, int flags)
{
    char path[256];
    snprintf(path, sizeof path, "%s/%s", lx_board_get()->functionfs, name);
    int fd = open(path, flags | O_CLOEXEC);
    if (fd < 0)
        lx_fail("open", path);
    return fd;
}

static int write_ep0(const void *data, size_t len, const char *what)
{
    if (write(U.ep0, data, len) == (ssize_t)len)
        return WDR_OK;
    char path[300];
    snprintf(path, sizeof path, "%s/ep0 (%s)", lx_board_get()->functionfs, what);
    return lx_fail("write", path);
}

/* The signal that wakes a thread out of a blocking FunctionFS read or write (EINTR): it does
 * nothing else, and has no SA_RESTART so that the call returns. */
static void on_wake(int sig) { (void)sig; }

static void catch_wake_signal(void)
{
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_wake;
    sigemptyset(&sa.sa_mask);
    sigaction(LX_USB_WAKE_SIGNAL, &sa, NULL);
}

int lx_usb_init(void)
{
    catch_wake_signal();
    atomic_store(&U.stopping, 0);
    U.ep0 = open_ep("ep0", O_RDWR);
    if (U.ep0 < 0)
        return WDR_E_IO;
    if (write_ep0(&descriptors, sizeof descriptors, "descriptors") != WDR_OK ||
        write_ep0(&strings, sizeof strings, "strings") != WDR_OK)
        return WDR_E_IO;
    U.ep_in = open_ep("ep1", O_WRONLY);
    U.ep_out = open_ep("ep2", O_RDONLY);
    if (U.ep_in < 0 || U.ep_out < 0)
        return WDR_E_IO;
    void *(*mains[3])(void *) = {ep0_main, rx_main, tx_main};
    for (int i = 0; i < 3; i++) {
        atomic_store(&U.ended[i], 0);
        int err = pthread_create(&U.threads[i], NULL, mains[i], NULL);
        if (err) {
            errno = err;
            return lx_fail("pthread_create", "USB thread");
        }
        U.n_threads = i + 1;
    }
    return WDR_OK;
}

static void close_ep(int *fd)
{
    if (*fd >= 0)
        close(*fd);
    *fd = -1;
}

/* Let what the firmware has queued leave first (the answer to REBOOT among it: the firmware
 * resets once hal_usb_write has taken its last bytes, which here means a buffer, not the wire),
 * while a host is there, for at most TX_DRAIN_MS. */
#define TX_DRAIN_MS 500

static void drain_tx(void)
{
    struct timespec until;
    clock_gettime(CLOCK_REALTIME, &until); /* the condition's clock */
    until.tv_nsec += (long)(TX_DRAIN_MS % 1000) * 1000000L;
    until.tv_sec += TX_DRAIN_MS / 1000 + until.tv_nsec / 1000000000L;
    until.tv_nsec %= 1000000000L;
    pthread_mutex_lock(&U.lock);
    while (U.connected && (U.tx_fill || U.tx_busy))
        if (pthread_cond_timedwait(&U.cond, &U.lock, &until) == ETIMEDOUT)
            break;
    pthread_mutex_unlock(&U.lock);
}

/* Wake thread i until it has returned, then join it. The signal is sent again every
 * millisecond: one sent just before the thread enters its read or write would be lost. */
static void stop_thread(int i)
{
    const struct timespec ms = {.tv_sec = 0, .tv_nsec = 1000000};
    while (!atomic_load(&U.ended[i])) {
        pthread_kill(U.threads[i], LX_USB_WAKE_SIGNAL);
        nanosleep(&ms, NULL);
    }
    pthread_join(U.threads[i], NULL);
}

/* The ep0 and IN threads are woken where they wait (read, write: a signal; the condition: a
 * broadcast) and return. They are not cancelled: a thread cancelled inside a system call
 * unwinds without unpoisoning its stack, and AddressSanitizer then reports a false
 * stack-buffer-overflow in sigaltstack as the thread exits (google/sanitizers#1399). The OUT
 * thread's AIO reads end with the endpoint (ESHUTDOWN) and it waits for a host that will not
 * come, until the process exits. Closing ep0 last makes the kernel unbind the gadget. */
void lx_usb_close(void)
{
    drain_tx();
    pthread_mutex_lock(&U.lock);
    U.connected = 0;
    atomic_store(&U.stopping, 1);
    pthread_cond_broadcast(&U.cond);
    pthread_mutex_unlock(&U.lock);
    for (int i = 0; i < U.n_threads; i++)
        if (i != 1) /* 1: rx_main, see above */
            stop_thread(i);
    U.n_threads = 0;
    close_ep(&U.ep_in);
    close_ep(&U.ep_out);
    close_ep(&U.ep0);
}

size_t hal_usb_max_transfer(void) { return MAX_TRANSFER; }

int hal_usb_read(uint8_t *buf, size_t cap)
{
    pthread_mutex_lock(&U.lock);
    int connected = U.connected;
    size_t n = 0;
    while (n < cap && U.r_tail != U.r_head)
        buf[n++] = U.ring[U.r_tail++ & (RX_RING - 1u)];
    if (n)
        pthread_cond_broadcast(&U.cond);
    pthread_mutex_unlock(&U.lock);
    return n || connected ? (int)n : WDR_E_IO;
}

/* The frame is copied: buf is free again at once, which HAL_EV_USB_TX_DONE says. */
int hal_usb_write(const uint8_t *buf, size_t len)
{
    if (len > MAX_TRANSFER)
        return WDR_E_TOO_LARGE;
    pthread_mutex_lock(&U.lock);
    int rc = !U.connected ? WDR_E_IO : MAX_TRANSFER - U.tx_fill < len ? WDR_E_BUSY : WDR_OK;
    if (rc == WDR_OK) {
        memcpy(U.tx[U.tx_filling] + U.tx_fill, buf, len);
        U.tx_fill += len;
        pthread_cond_broadcast(&U.cond);
    } else if (rc == WDR_E_BUSY) {
        U.tx_refused = 1;
    }
    pthread_mutex_unlock(&U.lock);
    if (rc == WDR_OK)
        lx_post(HAL_EV_USB_TX_DONE, 0);
    return rc;
}
