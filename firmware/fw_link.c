/* The link to the host: a queue of outgoing frames (one in flight on bulk IN at a time) and
 * the incoming byte stream cut into packets by the shared decoder. */
#include "fw_internal.h"
#include <string.h>

/* ---- Outgoing ---------------------------------------------------------------------------- */

int wdr_fw_tx_free(const wdr_fw *fw) { return WDR_FW_TX_SLOTS - fw->tx_count; }

/* The next free frame buffer; its payload starts at WDR_PROTO_HEADER_SIZE. NULL if none. */
uint8_t *wdr_fw_tx_reserve(wdr_fw *fw)
{
    if (fw->tx_count == WDR_FW_TX_SLOTS)
        return NULL;
    return (uint8_t *)fw->tx[(fw->tx_head + fw->tx_count) % WDR_FW_TX_SLOTS].words;
}

/* Seal the reserved buffer (payload already in place) and queue it. */
void wdr_fw_tx_commit(wdr_fw *fw, const wdr_proto_header *h, uint32_t len)
{
    wdr_fw_tx *t = &fw->tx[(fw->tx_head + fw->tx_count) % WDR_FW_TX_SLOTS];
    t->len = (uint32_t)wdr_proto_seal((uint8_t *)t->words, h, len);
    fw->tx_count++;
    wdr_fw_tx_kick(fw);
}

static void tx_pop(wdr_fw *fw)
{
    fw->tx_head = (uint8_t)((fw->tx_head + 1u) % WDR_FW_TX_SLOTS);
    fw->tx_count--;
}

/* Start the oldest queued frame if the endpoint is free. With no host to take them, frames
 * are dropped rather than stalling the sensor. */
void wdr_fw_tx_kick(wdr_fw *fw)
{
    while (!fw->tx_in_flight && fw->tx_count) {
        wdr_fw_tx *t = &fw->tx[fw->tx_head];
        int err = hal_usb_write((const uint8_t *)t->words, t->len);
        if (!err) {
            fw->tx_in_flight = true;
            return;
        }
        if (err == WDR_E_BUSY)
            return;
        tx_pop(fw);
    }
}

void wdr_fw_tx_done(wdr_fw *fw)
{
    if (fw->tx_in_flight) {
        fw->tx_in_flight = false;
        tx_pop(fw);
    }
    wdr_fw_tx_kick(fw);
}

/* ---- Incoming ------------------------------------------------------------------------------ */

/* Answer framing errors: the header was good, so the host learns which request failed. */
static void framing_error(wdr_fw *fw, const wdr_packet *pkt, int result)
{
    wdr_fw_reply(fw, &pkt->h, result == WDR_FEED_BAD_CRC ? WDR_ST_BAD_CRC : WDR_ST_TOO_LARGE, NULL, 0);
}

/* Handle at most one packet, and only when a response can be queued: bytes wait in the
 * endpoint otherwise, which is the flow control towards the host.
 * @return 1 if bytes were taken or a packet handled */
int wdr_fw_rx_service(wdr_fw *fw)
{
    if (!wdr_fw_tx_free(fw))
        return 0;
    if (fw->rx_pos == fw->rx_len) {
        int n = hal_usb_read(fw->rx, sizeof fw->rx);
        if (n <= 0 || (size_t)n > sizeof fw->rx) /* errors, and a backend breaking its contract */
            return 0;
        fw->rx_pos = 0;
        fw->rx_len = (uint32_t)n;
    }
    wdr_packet pkt;
    size_t used;
    int r = wdr_proto_feed(&fw->dec, fw->rx + fw->rx_pos, fw->rx_len - fw->rx_pos, &used, &pkt);
    fw->rx_pos += (uint32_t)used;
    if (r == WDR_FEED_PACKET)
        wdr_fw_handle(fw, &pkt);
    else if (r != WDR_FEED_MORE)
        framing_error(fw, &pkt, r);
    return 1;
}

/* Queue a frame already complete in the reserved buffer (a resent response). */
void wdr_fw_tx_commit_raw(wdr_fw *fw, uint32_t frame_len)
{
    fw->tx[(fw->tx_head + fw->tx_count) % WDR_FW_TX_SLOTS].len = frame_len;
    fw->tx_count++;
    wdr_fw_tx_kick(fw);
}
