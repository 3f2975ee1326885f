/* Real board on embedded Linux, USB: one vendor interface with a bulk IN and a bulk OUT
 * endpoint, served through FunctionFS (the gadget is assembled in configfs, see README.md).
 * Three threads stand in for the USB interrupts: ep0 events, OUT reads and IN writes; they
 * only move bytes and post events, the firmware's task loop does the rest. */
#include "hal_linux_internal.h"
#include <fcntl.h>
#include <linux/usb/functionfs.h>
#include <pthread.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>

#define RX_RING 65536u    /* power of two */
#define MAX_TRANSFER 65536u
#define HS_PACKET 512u
#define FS_PACKET 64u

static struct {
    pthread_mutex_t lock;
    pthread_cond_t cond;
    int ep0, ep_in, ep_out;
    int connected;
    uint8_t ring[RX_RING];
    uint32_t r_head, r_tail; /* free-running; fill = head - tail */
    const uint8_t *tx;
    size_t tx_len;
} U = {.lock = PTHREAD_MUTEX_INITIALIZER, .cond = PTHREAD_COND_INITIALIZER, .ep0 = -1, .ep_in = -1, .ep_out = -1};

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

static const struct {
    struct usb_functionfs_descs_head_v2 head;
    __le32 fs_count, hs_count;
    struct ep_pair fs, hs;
} __attribute__((packed)) descriptors = {
    .head = {.magic = LE(FUNCTIONFS_DESCRIPTORS_MAGIC_V2),
             .length = LE(sizeof descriptors),
             .flags = LE(FUNCTIONFS_HAS_FS_DESC | FUNCTIONFS_HAS_HS_DESC)},
    .fs_count = LE(3),
    .hs_count = LE(3),
#define WDR_INTF                                                                                                     \
    {.bLength = sizeof(struct usb_interface_descriptor), .bDescriptorType = USB_DT_INTERFACE, .bNumEndpoints = 2,   \
     .bInterfaceClass = 0xff, .bInterfaceSubClass = 0x57, .bInterfaceProtocol = 0x01, .iInterface = 1}
#define WDR_EP(addr, size)                                                                                           \
    {.bLength = USB_DT_ENDPOINT_SIZE, .bDescriptorType = USB_DT_ENDPOINT, .bEndpointAddress = (addr),               \
     .bmAttributes = USB_ENDPOINT_XFER_BULK, .wMaxPacketSize = LE(size)}
    .fs = {WDR_INTF, WDR_EP(1 | USB_DIR_IN, FS_PACKET), WDR_EP(2 | USB_DIR_OUT, FS_PACKET)},
    .hs = {WDR_INTF, WDR_EP(1 | USB_DIR_IN, HS_PACKET), WDR_EP(2 | USB_DIR_OUT, HS_PACKET)},
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

static void set_connected(int on)
{
    pthread_mutex_lock(&U.lock);
    U.connected = on;
    if (!on)
        U.r_head = U.r_tail = 0; /* a new host starts a new byte stream */
    pthread_cond_broadcast(&U.cond);
    pthread_mutex_unlock(&U.lock);
    lx_post(HAL_EV_USB_RESET, 0);
}

static void *ep0_main(void *arg)
{
    (void)arg;
    struct usb_functionfs_event ev;
    while (read(U.ep0, &ev, sizeof ev) == (ssize_t)sizeof ev) {
        if (ev.type == FUNCTIONFS_ENABLE)
            set_connected(1);
        else if (ev.type == FUNCTIONFS_DISABLE || ev.type == FUNCTIONFS_UNBIND || ev.type == FUNCTIONFS_SUSPEND)
            set_connected(0);
    }
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

static void *rx_main(void *arg)
{
    (void)arg;
    uint8_t pkt[HS_PACKET]; /* one packet per read: a read never waits for more than arrived */
    for (;;) {
        ssize_t n = read(U.ep_out, pkt, sizeof pkt);
        if (n > 0) {
            ring_put(pkt, (size_t)n);
            lx_post(HAL_EV_USB_RX, 0);
        } else {
            usleep(10000); /* endpoint disabled (no host): ep0 reports when it is back */
        }
    }
    return NULL;
}

static int write_all(const uint8_t *p, size_t len)
{
    while (len > 0) {
        ssize_t n = write(U.ep_in, p, len);
        if (n <= 0)
            return -1;
        p += n;
        len -= (size_t)n;
    }
    return 0;
}

static void *tx_main(void *arg)
{
    (void)arg;
    for (;;) {
        pthread_mutex_lock(&U.lock);
        while (!U.tx)
            pthread_cond_wait(&U.cond, &U.lock);
        const uint8_t *p = U.tx;
        size_t len = U.tx_len;
        pthread_mutex_unlock(&U.lock);
        /* A transfer that fills its last packet needs a zero-length packet to end it. */
        if (write_all(p, len) == 0 && len % FS_PACKET == 0 && write(U.ep_in, p, 0) < 0) {
            /* the host went away: ep0 reports the reset */
        }
        pthread_mutex_lock(&U.lock);
        U.tx = NULL;
        pthread_mutex_unlock(&U.lock);
        lx_post(HAL_EV_USB_TX_DONE, 0);
    }
    return NULL;
}

/* ---- Init and the HAL functions ---------------------------------------------------------------- */

static int open_ep(const char *name, int flags)
{
    char path[256];
    snprintf(path, sizeof path, "%s/%s", HAL_LINUX_FFS_DIR, name);
    return open(path, flags | O_CLOEXEC);
}

int lx_usb_init(void)
{
    U.ep0 = open_ep("ep0", O_RDWR);
    if (U.ep0 < 0 || write(U.ep0, &descriptors, sizeof descriptors) != (ssize_t)sizeof descriptors ||
        write(U.ep0, &strings, sizeof strings) != (ssize_t)sizeof strings)
        return WDR_E_IO;
    U.ep_in = open_ep("ep1", O_WRONLY);
    U.ep_out = open_ep("ep2", O_RDONLY);
    if (U.ep_in < 0 || U.ep_out < 0)
        return WDR_E_IO;
    pthread_t t;
    void *(*mains[3])(void *) = {ep0_main, rx_main, tx_main};
    for (int i = 0; i < 3; i++)
        if (pthread_create(&t, NULL, mains[i], NULL) != 0 || pthread_detach(t) != 0)
            return WDR_E_IO;
    return WDR_OK;
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

int hal_usb_write(const uint8_t *buf, size_t len)
{
    if (len > MAX_TRANSFER)
        return WDR_E_TOO_LARGE;
    pthread_mutex_lock(&U.lock);
    int rc = !U.connected ? WDR_E_IO : U.tx ? WDR_E_BUSY : WDR_OK;
    if (rc == WDR_OK) {
        U.tx = buf;
        U.tx_len = len;
        pthread_cond_broadcast(&U.cond);
    }
    pthread_mutex_unlock(&U.lock);
    return rc;
}
