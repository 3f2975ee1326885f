/* Not code: one array per RAM buffer of the firmware, each as large as that buffer, so that
 * `nm -S` on this object (cortex-m7-ram-map.cmake) prints the RAM map by buffer with the
 * target's own sizes and padding. Built for the cortex-m7 preset only, never linked. */
#include "wdr_fw.h"

#define WDR_BUF(name, member) char wdr_ram_##name[sizeof(((wdr_fw *)0)->member)]

WDR_BUF(lut_ram_active_and_staging, lut_ram);
WDR_BUF(cal_row, cal_row);
WDR_BUF(cal_shared_active_and_staging, cal_shared);
WDR_BUF(tx_frames, tx);
WDR_BUF(rx_chunk, rx);
WDR_BUF(decoder, dec);
WDR_BUF(raw_row, raw);
WDR_BUF(store, store);
WDR_BUF(last_response, last_response);
char wdr_ram_fw_total[sizeof(wdr_fw)];
