/* Flash table store: A/B slots per kind, commit marker last (SPEC.md, "Flash slot format").
 * Every HAL flash result is checked here and nowhere else. */
#include "crc32.h"
#include "wdr_store.h"
#include <string.h>

/* ---- Layout ------------------------------------------------------------------------------ */

static int is_pow2(uint32_t x) { return x && !(x & (x - 1u)); }

static uint32_t blocks_for(const hal_flash_geometry *g, uint32_t bytes)
{
    return (bytes + g->block_size - 1u) / g->block_size;
}

static int geometry_ok(const hal_flash_geometry *g)
{
    return is_pow2(g->block_size) && is_pow2(g->prog_size) && g->prog_size <= WDR_SLOT_MAX_PROG &&
           g->block_size >= WDR_SLOT_DATA_OFFSET && g->block_size >= g->prog_size;
}

static void slot_place(wdr_slot *s, uint32_t addr, uint32_t bytes, uint32_t cap_limit)
{
    memset(s, 0, sizeof *s);
    s->addr = addr;
    s->capacity = bytes - WDR_SLOT_DATA_OFFSET;
    if (cap_limit && s->capacity > cap_limit)
        s->capacity = cap_limit;
}

/* LUT A, LUT B, then the two CAL slots share what is left. */
static int partition(wdr_store *st, uint32_t lut_max)
{
    const hal_flash_geometry *g = &st->geo;
    uint32_t lut_blocks = blocks_for(g, WDR_SLOT_DATA_OFFSET + lut_max);
    if (g->block_count < 2u * lut_blocks + 2u)
        return WDR_E_UNSUPPORTED;
    uint32_t cal_blocks = (g->block_count - 2u * lut_blocks) / 2u;
    uint32_t lut_bytes = lut_blocks * g->block_size, cal_bytes = cal_blocks * g->block_size;
    slot_place(&st->slot[0][0], 0, lut_bytes, lut_max);
    slot_place(&st->slot[0][1], lut_bytes, lut_bytes, lut_max);
    slot_place(&st->slot[1][0], 2u * lut_bytes, cal_bytes, 0);
    slot_place(&st->slot[1][1], 2u * lut_bytes + cal_bytes, cal_bytes, 0);
    return WDR_OK;
}

/* ---- Slot header and marker --------------------------------------------------------------- */

typedef struct slot_header {
    uint32_t magic;
    uint16_t major, minor;
    uint8_t kind, index;
    wdr_store_id id;
    uint32_t length, seq, crc;
} slot_header;

static void header_pack(const slot_header *h, uint8_t *p)
{
    memset(p, 0, WDR_SLOT_HEADER_SIZE);
    wdr_put_u32(p + 0, h->magic);
    wdr_put_u16(p + 4, h->major);
    wdr_put_u16(p + 6, h->minor);
    p[8] = h->kind;
    p[9] = h->index;
    wdr_put_u32(p + 12, h->id.sensor_id);
    wdr_put_u16(p + 16, h->id.width);
    wdr_put_u16(p + 18, h->id.height);
    p[20] = h->id.dac_bits;
    p[21] = h->id.adc_bits;
    wdr_put_u32(p + 24, h->length);
    wdr_put_u32(p + 28, h->seq);
    wdr_put_u32(p + 32, h->crc);
    wdr_put_u32(p + 60, wdr_crc32(0, p, WDR_SLOT_HEADER_SIZE - 4u));
}

static void header_unpack(const uint8_t *p, slot_header *h)
{
    h->magic = wdr_get_u32(p + 0);
    h->major = wdr_get_u16(p + 4);
    h->minor = wdr_get_u16(p + 6);
    h->kind = p[8];
    h->index = p[9];
    h->id.sensor_id = wdr_get_u32(p + 12);
    h->id.width = wdr_get_u16(p + 16);
    h->id.height = wdr_get_u16(p + 18);
    h->id.dac_bits = p[20];
    h->id.adc_bits = p[21];
    h->length = wdr_get_u32(p + 24);
    h->seq = wdr_get_u32(p + 28);
    h->crc = wdr_get_u32(p + 32);
}

static int same_id(const wdr_store_id *a, const wdr_store_id *b)
{
    return a->sensor_id == b->sensor_id && a->width == b->width && a->height == b->height &&
           a->dac_bits == b->dac_bits && a->adc_bits == b->adc_bits;
}

/* Everything about the first 256 bytes of a slot that makes it a committed table of ours. */
static int header_valid(const wdr_store *st, const uint8_t *p, int kind, int index, const wdr_slot *s,
                        slot_header *h)
{
    header_unpack(p, h);
    if (h->magic != WDR_SLOT_MAGIC || wdr_get_u32(p + 60) != wdr_crc32(0, p, WDR_SLOT_HEADER_SIZE - 4u))
        return 0;
    if (h->major != WDR_SLOT_VERSION_MAJOR || h->kind != kind || h->index != index)
        return 0;
    if (!same_id(&h->id, &st->id) || h->length == 0 || h->length > s->capacity)
        return 0;
    const uint8_t *m = p + WDR_SLOT_MARKER_OFFSET;
    return wdr_get_u32(m) == WDR_SLOT_MARKER_MAGIC && wdr_get_u32(m + 4) == h->seq;
}

/* ---- Reading ------------------------------------------------------------------------------- */

int wdr_store_read(const wdr_store *st, int kind, int slot, uint32_t off, void *buf, uint32_t n)
{
    const wdr_slot *s = &st->slot[kind - 1][slot];
    if (off > s->capacity || n > s->capacity - off) /* subtraction, not off + n: no u32 wrap */
        return WDR_E_INVAL;
    return hal_flash_read(s->addr + WDR_SLOT_DATA_OFFSET + off, buf, n);
}

uint32_t wdr_store_length(const wdr_store *st, int kind, int slot)
{
    const wdr_slot *s = &st->slot[kind - 1][slot];
    return s->valid ? s->length : 0;
}

void wdr_store_forget(wdr_store *st, int kind, int slot) { st->slot[kind - 1][slot].valid = 0; }

int wdr_store_data_crc(wdr_store *st, const wdr_slot *s, uint32_t len, uint32_t *crc)
{
    uint32_t c = 0;
    for (uint32_t off = 0; off < len;) {
        uint32_t n = len - off < sizeof st->scratch ? len - off : (uint32_t)sizeof st->scratch;
        int err = hal_flash_read(s->addr + WDR_SLOT_DATA_OFFSET + off, st->scratch, n);
        if (err)
            return err;
        c = wdr_crc32(c, st->scratch, n);
        off += n;
    }
    *crc = c;
    return WDR_OK;
}

int wdr_store_scan_slot(wdr_store *st, int kind, int index)
{
    wdr_slot *s = &st->slot[kind - 1][index];
    slot_header h;
    s->valid = 0;
    int err = hal_flash_read(s->addr, st->scratch, WDR_SLOT_DATA_OFFSET);
    if (err)
        return err;
    if (!header_valid(st, st->scratch, kind, index, s, &h))
        return WDR_OK;
    uint32_t crc;
    err = wdr_store_data_crc(st, s, h.length, &crc);
    if (err)
        return err;
    s->seq = h.seq;
    s->length = h.length;
    s->crc = h.crc;
    s->valid = crc == h.crc;
    return WDR_OK;
}

int wdr_store_init(wdr_store *st, const wdr_store_id *id, uint32_t lut_max)
{
    memset(st, 0, sizeof *st);
    st->id = *id;
    int err = hal_flash_geometry_get(&st->geo);
    if (err)
        return err;
    if (!geometry_ok(&st->geo))
        return WDR_E_UNSUPPORTED;
    err = partition(st, lut_max);
    for (int kind = 1; !err && kind <= WDR_STORE_KINDS; kind++)
        for (int i = 0; !err && i < 2; i++)
            err = wdr_store_scan_slot(st, kind, i);
    return err;
}

static int newer(uint32_t a, uint32_t b) { return (int32_t)(a - b) > 0; }

int wdr_store_newest(const wdr_store *st, int kind, int exclude)
{
    const wdr_slot *s = st->slot[kind - 1];
    int best = -1;
    for (int i = 0; i < 2; i++)
        if (i != exclude && s[i].valid && (best < 0 || newer(s[i].seq, s[best].seq)))
            best = i;
    return best;
}

/* ---- Upload -------------------------------------------------------------------------------- */

static uint32_t next_seq(const wdr_store *st, int kind)
{
    int newest = wdr_store_newest(st, kind, -1);
    return newest < 0 ? 1u : st->slot[kind - 1][newest].seq + 1u;
}

/* Erase the slot's blocks up to end (exclusive) that are not erased yet. Erasing as data
 * arrives keeps every request short: a BEGIN never erases a whole multi-megabyte slot. */
static int erase_through(wdr_store *st, uint32_t end)
{
    while (st->up_erased < end) {
        int err = hal_flash_erase(st->up_erased / st->geo.block_size);
        if (err)
            return err;
        st->up_erased += st->geo.block_size;
    }
    return WDR_OK;
}

int wdr_store_begin(wdr_store *st, int kind, int active_slot, uint32_t len, uint32_t crc)
{
    int index = active_slot == 0 ? 1 : 0;
    wdr_slot *s = &st->slot[kind - 1][index];
    wdr_store_abort(st);
    if (len == 0)
        return WDR_E_INVAL;
    if (len > s->capacity)
        return WDR_E_TOO_LARGE;
    st->up_seq = next_seq(st, kind);
    s->valid = 0;
    st->up_erased = s->addr;
    /* The first block holds header and marker: once it is erased the slot is no table. */
    int err = erase_through(st, s->addr + WDR_SLOT_DATA_OFFSET);
    if (err)
        return err;
    st->up_kind = (uint8_t)kind;
    st->up_slot = (uint8_t)index;
    st->up_len = len;
    st->up_crc = crc;
    return WDR_OK;
}

static uint32_t data_addr(const wdr_store *st)
{
    return st->slot[st->up_kind - 1][st->up_slot].addr + WDR_SLOT_DATA_OFFSET + st->up_programmed;
}

static int prog_run(wdr_store *st, const uint8_t *p, uint32_t n)
{
    int err = erase_through(st, data_addr(st) + n);
    if (!err)
        err = hal_flash_prog(data_addr(st), p, n);
    if (!err)
        st->up_programmed += n;
    return err;
}

/* Append n bytes: whole program units straight from data, the rest held in tail. */
static int prog_append(wdr_store *st, const uint8_t *data, uint32_t n)
{
    const uint32_t unit = st->geo.prog_size;
    while (n && st->tail_fill) {
        st->tail[st->tail_fill++] = *data++;
        n--;
        if (st->tail_fill == unit) {
            int err = prog_run(st, st->tail, unit);
            if (err)
                return err;
            st->tail_fill = 0;
        }
    }
    uint32_t whole = n & ~(unit - 1u);
    if (whole) {
        int err = prog_run(st, data, whole);
        if (err)
            return err;
    }
    memcpy(st->tail, data + whole, n - whole);
    st->tail_fill = n - whole;
    return WDR_OK;
}

static int upload_check(const wdr_store *st, int kind)
{
    if (!st->up_kind)
        return WDR_E_SEQUENCE;
    return st->up_kind == kind ? WDR_OK : WDR_E_KIND;
}

int wdr_store_chunk(wdr_store *st, int kind, uint32_t offset, const uint8_t *data, uint32_t n)
{
    int err = upload_check(st, kind);
    if (err)
        return err;
    if (offset != st->up_received)
        return WDR_E_SEQUENCE;
    if (n > st->up_len - st->up_received)
        return WDR_E_TOO_LARGE;
    err = prog_append(st, data, n);
    if (err) {
        wdr_store_abort(st); /* the flash may hold part of it: start again */
        return err;
    }
    st->up_received += n;
    return WDR_OK;
}

int wdr_store_finish(wdr_store *st, int kind)
{
    int err = upload_check(st, kind);
    if (err)
        return err;
    if (st->up_received != st->up_len)
        return WDR_E_TRUNCATED;
    if (st->tail_fill) {
        memset(st->tail + st->tail_fill, 0xff, st->geo.prog_size - st->tail_fill);
        err = prog_run(st, st->tail, st->geo.prog_size);
        if (err)
            return err;
        st->tail_fill = 0;
    }
    uint32_t crc;
    err = wdr_store_data_crc(st, &st->slot[kind - 1][st->up_slot], st->up_len, &crc);
    if (err)
        return err;
    return crc == st->up_crc ? WDR_OK : WDR_E_CORRUPT;
}

/* Program one small record at a slot offset, padded with 0xFF to a program unit. */
static int prog_record(wdr_store *st, uint32_t addr, const uint8_t *rec, uint32_t n)
{
    uint32_t unit = st->geo.prog_size, len = (n + unit - 1u) & ~(unit - 1u);
    memset(st->scratch, 0xff, len);
    memcpy(st->scratch, rec, n);
    return hal_flash_prog(addr, st->scratch, len);
}

int wdr_store_seal(wdr_store *st)
{
    if (!st->up_kind)
        return WDR_E_SEQUENCE;
    int kind = st->up_kind, index = st->up_slot;
    wdr_slot *s = &st->slot[kind - 1][index];
    slot_header h = {WDR_SLOT_MAGIC, WDR_SLOT_VERSION_MAJOR, WDR_SLOT_VERSION_MINOR, (uint8_t)kind,
                     (uint8_t)index, st->id, st->up_len, st->up_seq, st->up_crc};
    uint8_t rec[WDR_SLOT_HEADER_SIZE];
    wdr_store_abort(st);
    header_pack(&h, rec);
    int err = prog_record(st, s->addr, rec, WDR_SLOT_HEADER_SIZE);
    if (err)
        return err;
    wdr_put_u32(rec, WDR_SLOT_MARKER_MAGIC);
    wdr_put_u32(rec + 4, h.seq);
    err = prog_record(st, s->addr + WDR_SLOT_MARKER_OFFSET, rec, 8);
    if (err)
        return err;
    err = wdr_store_scan_slot(st, kind, index);
    if (err)
        return err;
    return s->valid ? WDR_OK : WDR_E_CORRUPT;
}

void wdr_store_abort(wdr_store *st)
{
    st->up_kind = 0;
    st->up_received = st->up_programmed = st->tail_fill = 0;
}
