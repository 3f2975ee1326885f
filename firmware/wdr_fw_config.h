/* Build-time configuration of the firmware: every static buffer is sized here. A build may
 * point WDR_FW_CONFIG_FILE at its own header that defines some of these first; impossible
 * combinations stop the build below instead of failing on the board. */
#ifndef WDR_FW_CONFIG_H
#define WDR_FW_CONFIG_H
#ifdef WDR_FW_CONFIG_FILE
#include WDR_FW_CONFIG_FILE
#endif
#include "wdr_cal.h"
#include "wdr_lut.h"
#include "wdr_proto.h"

#define WDR_FW_VERSION_MAJOR 1
#define WDR_FW_VERSION_MINOR 1 /* 1.1: auto exposure */

#ifndef WDR_FW_LUT_MAX_ENTRIES
#define WDR_FW_LUT_MAX_ENTRIES 8192u /* a 12-bit stamped ramp has at most 4096 */
#endif
#ifndef WDR_FW_MAX_WIDTH
#define WDR_FW_MAX_WIDTH 1024u       /* widest sensor row */
#endif
#ifndef WDR_FW_MAX_CAL_COEFFS
#define WDR_FW_MAX_CAL_COEFFS 8u     /* coefficients per pixel the row buffer holds */
#endif
#ifndef WDR_FW_CAL_SHARED_MAX_FLOATS
#define WDR_FW_CAL_SHARED_MAX_FLOATS WDR_CAL_MAX_SHARED_FLOATS /* a BASIS table's shared block, in RAM */
#endif
#ifndef WDR_FW_CAL_CODES
#define WDR_FW_CAL_CODES 4096u       /* raw codes of a BASIS table's per-code points (12-bit ADC):
                                        4 * WDR_FW_MAX_CAL_COEFFS bytes each, in RAM */
#endif
#ifndef WDR_FW_TX_SLOTS
#define WDR_FW_TX_SLOTS 3u           /* outgoing frames: one in flight, the rest being filled */
#endif
#ifndef WDR_FW_RX_CHUNK
#define WDR_FW_RX_CHUNK 512u         /* bytes taken from the OUT endpoint at a time */
#endif
#ifndef WDR_FW_DAC_MIN_UPDATE_PS
#define WDR_FW_DAC_MIN_UPDATE_PS 1000u /* auto exposure: no DAC step shorter (1 GHz, the simulated DAC timer) */
#endif
#ifndef WDR_FW_MAX_INTEGRATION_NS
#define WDR_FW_MAX_INTEGRATION_NS 200000000u /* auto exposure: the longest integration the board allows */
#endif
#ifndef WDR_FW_EXPO_HIST
#define WDR_FW_EXPO_HIST 4096u       /* auto exposure: entries of the frame's code histogram (every 12-bit code) */
#endif
#ifndef WDR_FW_EXPO_DAMP_SHIFT
#define WDR_FW_EXPO_DAMP_SHIFT 1     /* auto exposure corrects 1/2^shift of the measured error per frame */
#endif
#ifndef WDR_FW_IMAGE_LOAD_LO
#define WDR_FW_IMAGE_LOAD_LO 0x00000000u /* uploaded images must load within [LO, HI): a board's */
#endif
#ifndef WDR_FW_IMAGE_LOAD_HI
#define WDR_FW_IMAGE_LOAD_HI 0xffffffffu /* config narrows it to its application RAM (hal/mps2) */
#endif
#ifndef WDR_FW_RESET_NS
#define WDR_FW_RESET_NS 2000u        /* reset pulse: settles N1 through M1 */
#endif

/* A LUT with a 1024-bin exposure block (4112 bytes) fits up to 7678 entries (a 12-bit ramp has at
 * most 4096): the slot layout, sized from this, stays. */
#define WDR_FW_LUT_MAX_BYTES (WDR_LUT_HEADER_SIZE + WDR_FW_LUT_MAX_ENTRIES * WDR_LUT_ENTRY_SIZE)
#define WDR_FW_CAL_ROW_MAX_BYTES (WDR_FW_MAX_CAL_COEFFS * 4u * WDR_FW_MAX_WIDTH + ((WDR_FW_MAX_WIDTH + 3u) & ~3u))
#define WDR_FW_RESPONSE_MAX 128u     /* largest response kept for retried requests */

#if WDR_FW_LUT_MAX_ENTRIES > WDR_LUT_MAX_ENTRIES || WDR_FW_LUT_MAX_ENTRIES < 2
#error "WDR_FW_LUT_MAX_ENTRIES must be within the LUT format's limits"
#endif
#if WDR_FW_MAX_WIDTH > WDR_PROTO_MAX_ROW_WIDTH
#error "WDR_FW_MAX_WIDTH: a row must fit one ROW packet"
#endif
#if WDR_FW_MAX_WIDTH > WDR_CAL_MAX_WIDTH
#error "WDR_FW_MAX_WIDTH exceeds what a calibration table can describe"
#endif
#if WDR_FW_MAX_CAL_COEFFS > WDR_CAL_MAX_COEFFS || WDR_FW_MAX_CAL_COEFFS < 3
#error "WDR_FW_MAX_CAL_COEFFS must hold a Moebius row (3) and at most WDR_CAL_MAX_COEFFS"
#endif
#if WDR_FW_CAL_SHARED_MAX_FLOATS > WDR_CAL_MAX_SHARED_FLOATS
#error "WDR_FW_CAL_SHARED_MAX_FLOATS exceeds what a calibration table can hold"
#endif
#if WDR_FW_CAL_CODES < 2
#error "WDR_FW_CAL_CODES: the per-code points need at least two codes"
#endif
#if WDR_FW_TX_SLOTS < 2 || WDR_FW_TX_SLOTS > 255
#error "WDR_FW_TX_SLOTS: READOUT needs one frame in flight and one being filled"
#endif
#if WDR_FW_RX_CHUNK < WDR_PROTO_HEADER_SIZE
#error "WDR_FW_RX_CHUNK must hold at least a frame header"
#endif
#if WDR_PROTO_HEADER_SIZE + WDR_INFO_SIZE > WDR_FW_RESPONSE_MAX || \
    WDR_PROTO_HEADER_SIZE + WDR_STATUS_SIZE > WDR_FW_RESPONSE_MAX
#error "WDR_FW_RESPONSE_MAX must hold every response"
#endif
#if WDR_FW_IMAGE_LOAD_LO >= WDR_FW_IMAGE_LOAD_HI
#error "WDR_FW_IMAGE_LOAD_LO must be below WDR_FW_IMAGE_LOAD_HI"
#endif
#if !defined(__BYTE_ORDER__) || __BYTE_ORDER__ != __ORDER_LITTLE_ENDIAN__
#error "ROW payloads are filled in place with native uint16: little-endian targets only"
#endif

#endif
