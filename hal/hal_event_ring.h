/* The fixed-size event queue of a backend (STYLE: interrupt-like events only post; the
 * firmware's task drains them through hal_event_poll). One ring for every backend and the tests'
 * fake board: a power-of-two array, one slot left free to tell full from empty. A single
 * producer and a single consumer need no lock on a Cortex-M; a backend with producer threads
 * serialises the posts itself. A post to a full ring is dropped: every event is also visible
 * as state (FIFO level, flags), so the firmware still finds the work. */
#ifndef HAL_EVENT_RING_H
#define HAL_EVENT_RING_H
#include "hal.h"
#include <stdint.h>

#define HAL_EVENT_RING_SIZE 64u /* power of two: at most 63 events wait */

typedef struct hal_event_ring {
    hal_event ev[HAL_EVENT_RING_SIZE];
    volatile uint32_t head, tail; /* head: next to write; tail: next to read */
} hal_event_ring;

static inline void hal_event_ring_reset(hal_event_ring *r) { r->head = r->tail = 0; }

static inline int hal_event_ring_empty(const hal_event_ring *r) { return r->head == r->tail; }

/* @return 1 when posted, 0 when the ring was full and the event dropped */
static inline int hal_event_ring_post(hal_event_ring *r, uint8_t type, uint32_t arg)
{
    uint32_t next = (r->head + 1u) & (HAL_EVENT_RING_SIZE - 1u);
    if (next == r->tail)
        return 0;
    r->ev[r->head] = (hal_event){.type = type, .arg = arg};
    r->head = next;
    return 1;
}

/* @return 1 with the oldest event in *ev, 0 when the ring is empty */
static inline int hal_event_ring_take(hal_event_ring *r, hal_event *ev)
{
    if (hal_event_ring_empty(r))
        return 0;
    *ev = r->ev[r->tail];
    r->tail = (r->tail + 1u) & (HAL_EVENT_RING_SIZE - 1u);
    return 1;
}

#endif
