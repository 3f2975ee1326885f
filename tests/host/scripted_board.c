/* Scripted fake board (see scripted_board.h). */
#include "scripted_board.h"
#include "crc32.h"
#include "wdr_lut.h"
#include <poll.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

static void send_all(scripted_board *b, const uint8_t *p, size_t len)
{
    while (len > 0 && b->fd >= 0) {
        ssize_t n = send(b->fd, p, len, MSG_NOSIGNAL);
        if (n <= 0)
            return;
        p += n;
        len -= (size_t)n;
    }
}

void fake_send_raw(scripted_board *b, const void *bytes, size_t len) { send_all(b, bytes, len); }

void fake_reply(scripted_board *b, const wdr_packet *req, int status, const void *payload, uint32_t len)
{
    uint8_t frame[WDR_PROTO_MAX_FRAME];
    wdr_proto_header h = {.opcode = req->h.opcode, .flags = WDR_FLAG_RESPONSE, .seq = req->h.seq,
                          .status = (uint8_t)status};
    size_t n = wdr_proto_encode(frame, sizeof frame, &h, payload, len);
    send_all(b, frame, n);
}

void fake_reply_bad_crc(scripted_board *b, const wdr_packet *req)
{
    uint8_t frame[WDR_PROTO_MAX_FRAME];
    uint8_t payload[4] = {1, 2, 3, 4};
    wdr_proto_header h = {.opcode = req->h.opcode, .flags = WDR_FLAG_RESPONSE, .seq = req->h.seq};
    size_t n = wdr_proto_encode(frame, sizeof frame, &h, payload, sizeof payload);
    frame[WDR_PROTO_HEADER_SIZE] ^= 0xff; /* payload no longer matches its CRC; header still does */
    send_all(b, frame, n);
}

void fake_event(scripted_board *b, uint8_t opcode, uint16_t seq, const void *payload, uint32_t len)
{
    uint8_t frame[WDR_PROTO_MAX_FRAME];
    wdr_proto_header h = {.opcode = opcode, .flags = WDR_FLAG_EVENT, .seq = seq};
    size_t n = wdr_proto_encode(frame, sizeof frame, &h, payload, len);
    send_all(b, frame, n);
}

void fake_reply_info(scripted_board *b, const wdr_packet *req, uint16_t major)
{
    wdr_info info = {.proto_major = major, .proto_minor = 0, .fw_major = 1, .sensor_id = 0x1234,
                     .width = b->width, .height = b->height, .adc_bits = 12, .dac_bits = 12,
                     .max_payload = WDR_PROTO_MAX_PAYLOAD, .lut_capacity = 1 << 20, .cal_capacity = 1 << 22,
                     .row_time_ns = 1000};
    strcpy(info.name, "fake");
    uint8_t p[WDR_INFO_SIZE];
    wdr_info_pack(&info, p);
    fake_reply(b, req, major == WDR_PROTO_VERSION_MAJOR ? WDR_ST_OK : WDR_ST_BAD_VERSION, p, sizeof p);
}

/* ---- The well-behaved board ---------------------------------------------------------------- */

static uint32_t up_crc, up_len;

static void send_frames(scripted_board *b, uint16_t seq, uint32_t frames)
{
    uint8_t row[WDR_PROTO_ROW_HEADER + 2 * 256];
    for (uint32_t f = 0; f < frames; f++) {
        for (uint16_t r = 0; r < b->height; r++) {
            wdr_put_u32(row, f);
            wdr_put_u16(row + 4, r);
            wdr_put_u16(row + 6, b->width);
            for (uint16_t i = 0; i < b->width; i++)
                wdr_put_u16(row + WDR_PROTO_ROW_HEADER + 2 * i, (uint16_t)((r * b->width + i + f) & 0xfff));
            fake_event(b, WDR_CMD_ROW, seq, row, WDR_PROTO_ROW_HEADER + 2u * b->width);
        }
        wdr_frame_end fe = {.frame = f, .rows = b->height};
        uint8_t p[WDR_FRAME_END_SIZE];
        wdr_frame_end_pack(&fe, p);
        fake_event(b, WDR_CMD_FRAME_END, seq, p, sizeof p);
    }
}

static void answer_upload(scripted_board *b, const wdr_packet *req)
{
    int step = req->h.opcode & 0x0f; /* BEGIN 0, CHUNK 1, COMMIT 2 */
    if (step == 0) {
        up_crc = 0;
        up_len = 0;
    } else if (step == 1) {
        up_crc = wdr_crc32(up_crc, req->payload + 4, req->h.length - 4);
        up_len += req->h.length - 4;
    }
    if (step != 2) {
        fake_reply(b, req, WDR_ST_OK, NULL, 0);
        return;
    }
    wdr_commit_reply r = {.crc = up_crc, .seq = 7, .slot = 1};
    uint8_t p[WDR_COMMIT_REPLY_SIZE];
    wdr_commit_pack(&r, p);
    fake_reply(b, req, WDR_ST_OK, p, sizeof p);
}

int fake_script_good(scripted_board *b, const wdr_packet *req, int n)
{
    (void)n;
    uint8_t st[WDR_STATUS_SIZE];
    wdr_status_report s = {.lut_slot = 0, .cal_slot = WDR_SLOT_NONE, .integration_ns = 1000000};
    switch (req->h.opcode) {
    case WDR_CMD_INFO: fake_reply_info(b, req, WDR_PROTO_VERSION_MAJOR); break;
    case WDR_CMD_STATUS:
        wdr_status_pack(&s, st);
        fake_reply(b, req, WDR_ST_OK, st, sizeof st);
        break;
    case WDR_CMD_LUT_BEGIN: case WDR_CMD_LUT_CHUNK: case WDR_CMD_LUT_COMMIT:
    case WDR_CMD_CAL_BEGIN: case WDR_CMD_CAL_CHUNK: case WDR_CMD_CAL_COMMIT: answer_upload(b, req); break;
    case WDR_CMD_CAPTURE:
        fake_reply(b, req, WDR_ST_OK, NULL, 0);
        send_frames(b, req->h.seq, wdr_get_u32(req->payload));
        break;
    default: fake_reply(b, req, WDR_ST_OK, NULL, 0); break;
    }
    return 0;
}

/* ---- The thread ------------------------------------------------------------------------------ */

/* Wait for fd to be readable in 50 ms slices, until stop. 1 ready, 0 stopped. */
static int wait_readable(scripted_board *b, int fd)
{
    while (!b->stop) {
        struct pollfd p = {.fd = fd, .events = POLLIN};
        if (poll(&p, 1, 50) > 0)
            return 1;
    }
    return 0;
}

static void serve(scripted_board *b)
{
    static __thread wdr_proto_decoder dec;
    uint8_t buf[8192];
    wdr_proto_decoder_init(&dec);
    while (wait_readable(b, b->fd)) {
        ssize_t n = recv(b->fd, buf, sizeof buf, 0);
        if (n <= 0)
            return;
        size_t pos = 0;
        while (pos < (size_t)n) {
            size_t used = 0;
            wdr_packet p;
            int r = wdr_proto_feed(&dec, buf + pos, (size_t)n - pos, &used, &p);
            pos += used;
            if (r != WDR_FEED_PACKET)
                continue;
            b->opcodes[p.h.opcode]++;
            b->last_seq = p.h.seq;
            if (b->script(b, &p, b->requests++) < 0)
                return;
        }
    }
}

static void *fake_main(void *arg)
{
    scripted_board *b = arg;
    for (int session = 0; session < (b->sessions > 0 ? b->sessions : 1); session++) {
        if (session && b->fd >= 0) {
            close(b->fd); /* a board that reset: the next host finds it listening again */
            b->fd = -1;
        }
        if (b->listen_fd >= 0) {
            if (!wait_readable(b, b->listen_fd))
                return NULL;
            b->fd = accept(b->listen_fd, NULL, NULL);
        }
        if (b->fd >= 0)
            serve(b);
        if (b->fd >= 0)
            shutdown(b->fd, SHUT_RDWR); /* the hang-up the host must notice */
    }
    return NULL;
}

static void init(scripted_board *b, fake_script script)
{
    if (!b->width)
        b->width = 16;
    if (!b->height)
        b->height = 8;
    b->script = script;
    b->stop = 0;
    b->requests = 0;
    memset(b->opcodes, 0, sizeof b->opcodes);
}

void scripted_board_start_fd(scripted_board *b, int fd, fake_script script)
{
    init(b, script);
    b->fd = fd;
    b->listen_fd = -1;
    pthread_create(&b->thread, NULL, fake_main, b);
}

int scripted_board_start_listen(scripted_board *b, const char *path, fake_script script)
{
    struct sockaddr_un sa = {.sun_family = AF_UNIX};
    init(b, script);
    b->fd = -1;
    strncpy(sa.sun_path, path, sizeof sa.sun_path - 1);
    b->listen_fd = socket(AF_UNIX, SOCK_STREAM, 0);
    if (b->listen_fd < 0 || bind(b->listen_fd, (struct sockaddr *)&sa, sizeof sa) < 0 || listen(b->listen_fd, 2) < 0)
        return -1;
    pthread_create(&b->thread, NULL, fake_main, b);
    return 0;
}

void scripted_board_stop(scripted_board *b)
{
    b->stop = 1;
    pthread_join(b->thread, NULL);
    if (b->fd >= 0)
        close(b->fd);
    if (b->listen_fd >= 0)
        close(b->listen_fd);
    b->fd = b->listen_fd = -1;
}
