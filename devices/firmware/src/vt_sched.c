/* Per-channel scheduler (docs/device-protocol.md §2 SET_PATTERN and timing rule).
 *
 * Event-driven: each channel keeps the time of its next gate toggle, and the next toggle is
 * computed from the previous *scheduled* time (t + on_us / t + off_us), never from when the
 * caller happened to look, so a late vt_device_advance never stretches the pattern. Every edge
 * carries its exact scheduled time, as if a hardware timer alarm had fired at it. */
#include <string.h>

#include "viestac_fw.h"

static int timed(const vt_channel *c)
{
    return (c->mode == VT_MODE_PULSE || c->mode == VT_MODE_TEXTURE) && c->on_us && c->off_us;
}

static uint8_t gate_of(const vt_channel *c)
{
    switch (c->mode) {
    case VT_MODE_CONTINUOUS: return 1;
    case VT_MODE_PULSE:
    case VT_MODE_TEXTURE:
        if (c->on_us == 0) return 0;      /* on_us = 0: always off */
        if (c->off_us == 0) return 1;     /* off_us = 0: always on */
        return c->phase_on;
    default: return 0;
    }
}

static vt_edge output_of(const vt_device *d, uint8_t i, uint64_t t, uint8_t cause)
{
    const vt_channel *c = &d->ch[i];
    vt_edge e;
    memset(&e, 0, sizeof e);
    e.t_us = t;
    e.channel = i;
    e.gate = gate_of(c);
    e.mode = c->mode;
    e.intensity = c->intensity;
    /* texture has no carrier: the switching itself is the vibration (§2 mode 3) */
    if (c->mode == VT_MODE_PULSE || c->mode == VT_MODE_CONTINUOUS)
        e.carrier_hz = c->carrier_hz ? c->carrier_hz : d->model->carrier_hz;
    e.direction_cdeg = c->direction_cdeg;
    e.magnitude = c->magnitude;
    /* a layer that is off reports 0, so a value kept by STOP never tells two edges apart */
    e.temperature_on = c->temperature_on;
    e.centi_celsius = c->temperature_on ? c->centi_celsius : 0;
    e.friction_on = c->friction_on;
    e.friction_milli = c->friction_on ? c->friction_milli : 0;
    e.cause = cause;
    return e;
}

static int same_output(const vt_edge *a, const vt_edge *b)
{
    return a->gate == b->gate && a->mode == b->mode && a->intensity == b->intensity &&
           a->carrier_hz == b->carrier_hz && a->direction_cdeg == b->direction_cdeg &&
           a->magnitude == b->magnitude && a->temperature_on == b->temperature_on &&
           a->centi_celsius == b->centi_celsius && a->friction_on == b->friction_on &&
           a->friction_milli == b->friction_milli;
}

static void queue_push(vt_device *d, const vt_edge *e)
{
    if (d->q_len == VT_EDGE_QUEUE) {          /* the state still changed; only the report is lost */
        d->counters[VT_CNT_EDGES_DROPPED]++;
        return;
    }
    d->q[(d->q_head + d->q_len) % VT_EDGE_QUEUE] = *e;
    d->q_len++;
}

static int earliest(const vt_device *d)
{
    int best = -1;
    for (int i = 0; i < d->model->channels; i++)
        if (d->ch[i].next_us != VT_NEVER && (best < 0 || d->ch[i].next_us < d->ch[best].next_us))
            best = i;
    return best;
}

/* Toggle channel i at its scheduled time and return the resulting output. */
static vt_edge fire(vt_device *d, int i)
{
    vt_channel *c = &d->ch[i];
    uint64_t t = c->next_us;
    c->phase_on = !c->phase_on;
    c->next_us = t + (c->phase_on ? c->on_us : c->off_us);
    c->last = output_of(d, (uint8_t)i, t, VT_CAUSE_SCHEDULE);
    return c->last;
}

void vt_sched_init(vt_device *d)
{
    for (uint8_t i = 0; i < VT_MAX_CHANNELS; i++) {
        memset(&d->ch[i], 0, sizeof d->ch[i]);
        d->ch[i].next_us = VT_NEVER;
        d->ch[i].last = output_of(d, i, 0, VT_CAUSE_STATE);
    }
}

void vt_sched_catch_up(vt_device *d, uint64_t now_us)
{
    int i;
    while ((i = earliest(d)) >= 0 && d->ch[i].next_us <= now_us) {
        vt_edge e = fire(d, i);
        queue_push(d, &e);
    }
}

void vt_sched_commit(vt_device *d, uint8_t i, int restart, uint64_t now_us, uint8_t cause)
{
    vt_channel *c = &d->ch[i];
    if (restart) {                            /* "restarts the pattern with its on-phase" (§2) */
        c->phase_on = 1;
        c->next_us = timed(c) ? now_us + c->on_us : VT_NEVER;
    }
    vt_edge e = output_of(d, i, now_us, cause);
    if (!same_output(&e, &c->last)) {
        c->last = e;
        queue_push(d, &e);
    }
}

size_t vt_device_advance(vt_device *d, uint64_t now_us, vt_edge *edges, size_t max)
{
    size_t n = 0;
    vt_watchdog_check(d, now_us);              /* its edges join the queue, in time order */
    /* queued edges are all at or before the last receive, so they come first */
    while (n < max && d->q_len) {
        edges[n++] = d->q[d->q_head];
        d->q_head = (uint8_t)((d->q_head + 1) % VT_EDGE_QUEUE);
        d->q_len--;
    }
    int i;
    while (n < max && d->q_len == 0 && (i = earliest(d)) >= 0 && d->ch[i].next_us <= now_us)
        edges[n++] = fire(d, i);
    return n;
}

uint64_t vt_device_next_edge_us(const vt_device *d)
{
    if (d->q_len)
        return d->q[d->q_head].t_us;
    int i = earliest(d);
    uint64_t t = i < 0 ? VT_NEVER : d->ch[i].next_us;
    return d->wd_deadline_us < t ? d->wd_deadline_us : t;
}
