/* bench_target's Cortex-M7 half: runs on QEMU's mps2-an500 under -icount shift=0 (one virtual
 * nanosecond per instruction) and counts, with CMSDK timer 0 (25 MHz: 40 instructions a tick),
 * the instructions of the firmware's correction kernel and of its whole row path
 * (wdr_readout_row: correction, ROW framing, CRC) per pixel, for every table form. The tables
 * and frames are the target test's (target_data), loaded into PSRAM by QEMU's -device loader.
 * Prints one line per form on UART0: "form NAME corr_milli_insn row_milli_insn", then "done". */
#include "mps2_board.h"
#include "correct.h"
#include "crc32.h"
#include "wdr_cal.h"
#include "wdr_proto.h"
#include "wdr_readout.h"
#include <stdint.h>
#include <string.h>

#define REG(addr) (*(volatile uint32_t *)(uintptr_t)(addr))
#define TABLE_AT(i) (MPS2_PSRAM_BASE + (uint32_t)(i)*0x100000u) /* 1 MiB apart, below the replay */
#define ROUNDS 4

extern uint32_t _stack_top, _data_load, _data_start, _data_end, _bss_start, _bss_end;
void wdr_reset_handler(void);
static void park(void)
{
    for (;;) {
    }
}
__attribute__((section(".isr_vector"), used)) static void (*const vectors[16])(void) = {
    (void (*)(void))(uintptr_t)&_stack_top,
    wdr_reset_handler,
    park,
    park,
    park,
    park,
    park,
    0,
    0,
    0,
    0,
    park,
    park,
    0,
    park,
    park,
};

static float basis_points[4096 * 8];
static uint32_t compact_points[8192 * 4]; /* SHIFTED: one USAT a pixel (correct.c) */
static uint16_t out_row[1024];
static uint32_t frame[(WDR_PROTO_MAX_FRAME + 3u) / 4u];

static void put(const char *s)
{
    for (; *s; s++) {
        while (REG(MPS2_UART0_BASE + 4u) & 1u) {
        }
        REG(MPS2_UART0_BASE) = (uint8_t)*s;
    }
}

static void put_u32(uint32_t v)
{
    char b[12], *p = b + 11;
    *p = 0;
    do
        *--p = (char)('0' + v % 10u);
    while (v /= 10u);
    put(p);
}

static uint32_t ticks(void)
{
    return REG(MPS2_TIMER0_BASE + 4u);
} /* counts down */

static const uint16_t *raw_row(int r)
{
    const uint8_t *rp = (const uint8_t *)(uintptr_t)MPS2_REPLAY_BASE;
    return (const uint16_t *)(const void *)(rp + 16) + (size_t)r * ((const uint16_t *)(const void *)rp)[2];
}

/* Milli-instructions per pixel of ROUNDS passes over every row, correction alone or row path. */
static uint32_t count(const wdr_cal_view *v, int row_path)
{
    uint32_t len, t0 = ticks();
    for (int k = 0; k < ROUNDS; k++)
        for (int r = 0; r < v->h.height; r++) {
            if (!row_path) {
                wdr_correct_row(v, r, raw_row(r), out_row);
                continue;
            }
            const uint32_t *block = NULL;
            if (v->payload) /* the firmware's cal_row: the row block copied from table flash */
                block = (const uint32_t *)(const void *)(v->payload + (size_t)r * v->row_stride);
            wdr_readout_row(v, block, (uint16_t)r, 1, 1, raw_row(r), (uint8_t *)frame, &len);
        }
    uint64_t insn = (uint64_t)(t0 - ticks()) * (1000000000u / MPS2_SYSCLK_HZ);
    return (uint32_t)(insn * 1000u / ((uint64_t)ROUNDS * v->h.width * v->h.height));
}

static void bench(const char *name, wdr_cal_view *v)
{
    put("form ");
    put(name);
    put(" ");
    put_u32(count(v, 0));
    put(" ");
    put_u32(count(v, 1));
    put("\n");
}

static void bench_table(const char *name, int slot)
{
    const uint8_t *p = (const uint8_t *)(uintptr_t)TABLE_AT(slot);
    wdr_cal_view v;
    if (wdr_cal_parse(p, 0x200000u, &v)) {
        put("form ");
        put(name);
        put(" unparsed\n");
        return;
    }
    if (v.h.form == WDR_FORM_BASIS)
        wdr_correct_per_code(&v, basis_points, sizeof basis_points / sizeof(float));
    if (wdr_cal_form_compact(v.h.form))
        wdr_correct_per_code_compact(&v, compact_points, sizeof compact_points / sizeof(uint32_t));
    bench(name, &v);
}

int main(void)
{
    REG(MPS2_TIMER0_BASE) = 0;
    REG(MPS2_TIMER0_BASE + 8u) = 0xffffffffu;
    REG(MPS2_TIMER0_BASE + 4u) = 0xffffffffu;
    REG(MPS2_TIMER0_BASE) = 1u;
    REG(MPS2_UART0_BASE + 0x10u) = MPS2_UART_BAUDDIV;
    REG(MPS2_UART0_BASE + 8u) = 1u;
    const uint16_t *rp = (const uint16_t *)(uintptr_t)MPS2_REPLAY_BASE;
    wdr_cal_view id;
    wdr_cal_identity(&id, MPS2_SENSOR_ID, rp[2], rp[3], 1.0f, 4095, 4095);
    bench("identity", &id);
    static const char *const names[5] = {"moebius", "poly", "basis", "compact", "shifted"};
    for (int i = 0; i < 5; i++)
        bench_table(names[i], i);
    put("done\n");
    return 0;
}

void wdr_reset_handler(void)
{
    memcpy(&_data_start, &_data_load, (size_t)((uint8_t *)&_data_end - (uint8_t *)&_data_start));
    memset(&_bss_start, 0, (size_t)((uint8_t *)&_bss_end - (uint8_t *)&_bss_start));
    *(volatile uint32_t *)0xE000ED88u |= 0xFu << 20; /* the FPU */
    __asm volatile("dsb\n isb");
    main();
    park();
}
