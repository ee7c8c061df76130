/* Command dispatch, replies and counters (docs/device-protocol.md §1-§3). */
#include <string.h>

#include "viestac_fw.h"

static uint16_t rd16(const uint8_t *p) { return (uint16_t)(p[0] | (p[1] << 8)); }
static uint32_t rd32(const uint8_t *p) { return (uint32_t)rd16(p) | ((uint32_t)rd16(p + 2) << 16); }

size_t vt_device_sizeof(void) { return sizeof(vt_device); }
size_t vt_edge_sizeof(void) { return sizeof(vt_edge); }
size_t vt_channel_sizeof(void) { return sizeof(vt_channel); }

size_t vt_edge_offset(int k)
{
    static const size_t offsets[] = {
        offsetof(vt_edge, t_us), offsetof(vt_edge, channel), offsetof(vt_edge, gate),
        offsetof(vt_edge, mode), offsetof(vt_edge, intensity), offsetof(vt_edge, carrier_hz),
        offsetof(vt_edge, direction_cdeg), offsetof(vt_edge, centi_celsius),
        offsetof(vt_edge, friction_milli), offsetof(vt_edge, magnitude),
        offsetof(vt_edge, temperature_on), offsetof(vt_edge, friction_on), offsetof(vt_edge, cause)
    };
    return k >= 0 && (size_t)k < sizeof offsets / sizeof offsets[0] ? offsets[k] : (size_t)-1;
}

int vt_device_init(vt_device *d, const vt_model *m)
{
    if (!m || m->channels == 0 || m->channels > VT_MAX_CHANNELS)
        return -1;
    memset(d, 0, sizeof *d);
    d->model = m;
    vt_decoder_init(&d->dec);
    vt_sched_init(d);
    d->wd_ms = VT_WATCHDOG_BOOT_MS;
    d->wd_deadline_us = VT_NEVER;
    return 0;
}

int vt_device_set_watchdog(vt_device *d, uint32_t timeout_ms)
{
    if (timeout_ms != 0 && (timeout_ms < VT_WATCHDOG_MIN_MS || timeout_ms > VT_WATCHDOG_MAX_MS))
        return -1;
    d->wd_ms = timeout_ms;
    if (timeout_ms == 0)
        d->wd_deadline_us = VT_NEVER;
    return 0;
}

uint64_t vt_device_watchdog_deadline_us(const vt_device *d) { return d->wd_deadline_us; }

/* Every layer of every channel off at the expiry time itself, as STOP 0xFF would (§2), then
 * disarmed until the next valid frame: one trip per silence. */
void vt_watchdog_check(vt_device *d, uint64_t now_us)
{
    uint64_t t = d->wd_deadline_us;
    if (t > now_us)
        return;
    d->wd_deadline_us = VT_NEVER;
    vt_sched_catch_up(d, t);                   /* toggles before the expiry come first */
    for (uint8_t i = 0; i < d->model->channels; i++) {
        vt_channel *c = &d->ch[i];
        c->mode = VT_MODE_OFF; c->intensity = 0; c->carrier_hz = 0; c->on_us = 0; c->off_us = 0;
        c->magnitude = 0;
        c->temperature_on = 0; c->friction_on = 0;
        vt_sched_commit(d, i, 1, t, VT_CAUSE_WATCHDOG);
    }
    d->counters[VT_CNT_WATCHDOG_TRIPS]++;
    d->wd_report = d->wd_host;
}

/* Queue one frame for the host. A full buffer drops the whole reply (never half a frame) and
 * does not use up a sequence number. */
static void send(vt_device *d, uint8_t type, const uint8_t *payload, size_t plen)
{
    uint8_t buf[VT_MAX_WIRE];
    size_t n = vt_frame_encode(type, d->tx_seq, payload, plen, buf, sizeof buf);
    if (n == 0 || n > VT_OUT_SIZE - d->out_len) {
        d->counters[VT_CNT_REPLIES_DROPPED]++;
        return;
    }
    for (size_t k = 0; k < n; k++)
        d->out[(d->out_head + d->out_len + k) % VT_OUT_SIZE] = buf[k];
    d->out_len = (uint16_t)(d->out_len + n);
    d->tx_seq++;
}

static void reject(vt_device *d, int counter, uint8_t ref_seq, uint8_t code)
{
    uint8_t p[2] = { ref_seq, code };
    d->counters[counter]++;
    send(d, VT_ERROR, p, sizeof p);
}

static void identify(vt_device *d)
{
    const vt_model *m = d->model;
    size_t n = strlen(m->name);
    uint8_t p[9 + 32];
    if (n > 32)
        n = 32;
    p[0] = VT_PROTOCOL_VERSION;
    p[1] = m->fw_major; p[2] = m->fw_minor; p[3] = m->fw_patch;
    p[4] = m->channels; p[5] = m->caps;
    p[6] = (uint8_t)(m->carrier_hz & 0xFF); p[7] = (uint8_t)(m->carrier_hz >> 8);
    p[8] = (uint8_t)n;
    memcpy(p + 9, m->name, n);
    send(d, VT_IDENTIFY, p, 9 + n);
}

/* The four SET commands and STOP. Checks come first and a failing command changes nothing
 * (§3). Order: the layer's capability, the channel, then values (for SET_PATTERN the mode's
 * capability is checked once the mode is known to be valid). Returns 0 or an ERROR code. */
static int apply(vt_device *d, uint8_t type, const uint8_t *p, uint64_t now)
{
    const vt_model *m = d->model;
    if ((type == VT_SET_TILT && !(m->caps & VT_CAP_TILT)) ||
        (type == VT_SET_TEMPERATURE && !(m->caps & VT_CAP_TEMPERATURE)) ||
        (type == VT_SET_FRICTION && !(m->caps & VT_CAP_FRICTION)))
        return VT_ERR_UNSUPPORTED;
    uint8_t first = p[0], end = (uint8_t)(p[0] + 1);
    if (p[0] == VT_CHANNEL_ALL) {
        first = 0;
        end = m->channels;
    } else if (p[0] >= m->channels) {
        return VT_ERR_BAD_CHANNEL;
    }

    switch (type) {
    case VT_SET_PATTERN: {
        uint8_t mode = p[1], intensity = p[2];
        uint16_t carrier = rd16(p + 3);
        uint32_t on = rd32(p + 5), off = rd32(p + 9);
        if (mode > VT_MODE_TEXTURE)
            return VT_ERR_BAD_VALUE;
        if (mode != VT_MODE_OFF && !(m->caps & (1u << (mode - 1))))
            return VT_ERR_UNSUPPORTED;
        if (intensity > 100 || on > VT_MAX_ON_OFF_US || off > VT_MAX_ON_OFF_US)
            return VT_ERR_BAD_VALUE;
        vt_sched_catch_up(d, now);
        for (uint8_t i = first; i < end; i++) {
            vt_channel *c = &d->ch[i];
            if (c->mode == mode && c->intensity == intensity && c->carrier_hz == carrier &&
                c->on_us == on && c->off_us == off)
                continue;                      /* the same pattern: its phase goes on (§2) */
            c->mode = mode; c->intensity = intensity; c->carrier_hz = carrier;
            c->on_us = on; c->off_us = off;
            vt_sched_commit(d, i, 1, now, VT_CAUSE_COMMAND);
        }
        return 0;
    }
    case VT_SET_TILT: {
        uint16_t direction = rd16(p + 1);
        if (direction > 35999 || p[3] > 100)
            return VT_ERR_BAD_VALUE;
        vt_sched_catch_up(d, now);
        for (uint8_t i = first; i < end; i++) {
            d->ch[i].direction_cdeg = direction;
            d->ch[i].magnitude = p[3];
            vt_sched_commit(d, i, 0, now, VT_CAUSE_COMMAND);     /* tilt never touches the pattern's phase */
        }
        return 0;
    }
    case VT_SET_TEMPERATURE:
    case VT_SET_FRICTION: {
        uint16_t v = rd16(p + 1);              /* a negative i16 reads as >= 0x8000 */
        if (v > 5000)
            return VT_ERR_BAD_VALUE;
        vt_sched_catch_up(d, now);
        for (uint8_t i = first; i < end; i++) {
            if (type == VT_SET_TEMPERATURE) {
                d->ch[i].temperature_on = 1;
                d->ch[i].centi_celsius = (int16_t)v;
            } else {
                d->ch[i].friction_on = 1;
                d->ch[i].friction_milli = v;
            }
            vt_sched_commit(d, i, 0, now, VT_CAUSE_COMMAND);     /* like tilt: the pattern's phase goes on */
        }
        return 0;
    }
    default: /* VT_STOP: pattern off, tilt flat, temperature and friction off (§2) */
        vt_sched_catch_up(d, now);
        for (uint8_t i = first; i < end; i++) {
            vt_channel *c = &d->ch[i];
            c->mode = VT_MODE_OFF; c->intensity = 0; c->carrier_hz = 0; c->on_us = 0; c->off_us = 0;
            c->magnitude = 0;
            c->temperature_on = 0; c->friction_on = 0;
            vt_sched_commit(d, i, 1, now, VT_CAUSE_COMMAND);
        }
        return 0;
    }
}

static void dispatch(vt_device *d, const vt_frame *f, uint64_t now)
{
    int err = vt_message_check(f->type, f->payload, f->len);
    if (err == VT_ERR_UNKNOWN_TYPE) {
        reject(d, VT_CNT_UNKNOWN_TYPE, f->seq, VT_ERR_UNKNOWN_TYPE);
        return;
    }
    if (err == VT_ERR_BAD_LENGTH) {            /* §3: ref_seq 0xFF for bad_length */
        reject(d, VT_CNT_BAD_LENGTH, 0xFF, VT_ERR_BAD_LENGTH);
        return;
    }
    d->counters[VT_CNT_FRAMES_OK]++;
    if (f->type & 0x80) {
        /* A device-to-host frame (e.g. our own replies on a looped-back line): never answer
         * it, or two devices could echo errors at each other for ever. */
        d->counters[VT_CNT_IGNORED]++;
        return;
    }
    /* a valid host frame: the host is alive. The trip it may come after is reported first, so
     * the host knows every layer went off and sends them again (§4.4). */
    vt_watchdog_check(d, now);
    if (d->wd_ms)
        d->wd_deadline_us = now + (uint64_t)d->wd_ms * 1000u;
    if (d->wd_report) {
        uint32_t trips = d->counters[VT_CNT_WATCHDOG_TRIPS];
        uint8_t p[4] = { (uint8_t)(d->wd_ms & 0xFF), (uint8_t)(d->wd_ms >> 8),
                         (uint8_t)(trips > 0xFFFF ? 0xFF : trips & 0xFF), (uint8_t)(trips > 0xFFFF ? 0xFF : trips >> 8) };
        d->wd_report = 0;
        send(d, VT_WATCHDOG, p, sizeof p);
    }
    switch (f->type) {
    case VT_HELLO:
        if (f->payload[0] != VT_PROTOCOL_VERSION)   /* §6: keep serving version 1 */
            reject(d, VT_CNT_BAD_VERSION, f->seq, VT_ERR_BAD_VERSION);
        else
            identify(d);
        return;
    case VT_PING:
        send(d, VT_PONG, f->payload, 4);
        return;
    case VT_SET_WATCHDOG:
        if (vt_device_set_watchdog(d, rd16(f->payload)) != 0) {
            reject(d, VT_CNT_BAD_VALUE, f->seq, VT_ERR_BAD_VALUE);
            return;
        }
        d->wd_host = 1;
        d->wd_deadline_us = d->wd_ms ? now + (uint64_t)d->wd_ms * 1000u : VT_NEVER;
        send(d, VT_ACK, &f->seq, 1);
        return;
    default:
        err = apply(d, f->type, f->payload, now);
        if (err == VT_ERR_BAD_VALUE) reject(d, VT_CNT_BAD_VALUE, f->seq, (uint8_t)err);
        else if (err == VT_ERR_UNSUPPORTED) reject(d, VT_CNT_UNSUPPORTED, f->seq, (uint8_t)err);
        else if (err == VT_ERR_BAD_CHANNEL) reject(d, VT_CNT_BAD_CHANNEL, f->seq, (uint8_t)err);
        else send(d, VT_ACK, &f->seq, 1);
    }
}

void vt_device_receive(vt_device *d, const uint8_t *data, size_t len, uint64_t now_us)
{
    vt_frame f;
    for (size_t k = 0; k < len; k++) {
        /* §1: the sequence number of a frame that failed here cannot be trusted: ref_seq 0xFF */
        switch (vt_decoder_feed(&d->dec, data[k], &f)) {
        case VT_DEC_FRAME: dispatch(d, &f, now_us); break;
        case VT_DEC_FRAMING: reject(d, VT_CNT_FRAMING, 0xFF, VT_ERR_FRAMING); break;
        case VT_DEC_TOO_LONG: reject(d, VT_CNT_TOO_LONG, 0xFF, VT_ERR_BAD_LENGTH); break;
        case VT_DEC_BAD_LENGTH: reject(d, VT_CNT_BAD_LENGTH, 0xFF, VT_ERR_BAD_LENGTH); break;
        case VT_DEC_BAD_CRC: reject(d, VT_CNT_BAD_CRC, 0xFF, VT_ERR_BAD_CRC); break;
        default: break;
        }
    }
}

size_t vt_device_take_output(vt_device *d, uint8_t *dst, size_t cap)
{
    size_t n = 0;
    while (n < cap && d->out_len) {
        dst[n++] = d->out[d->out_head];
        d->out_head = (uint16_t)((d->out_head + 1) % VT_OUT_SIZE);
        d->out_len--;
    }
    return n;
}

size_t vt_device_output_pending(const vt_device *d) { return d->out_len; }

const vt_channel *vt_device_channel(const vt_device *d, uint8_t channel)
{
    return channel < d->model->channels ? &d->ch[channel] : NULL;
}

uint32_t vt_device_counter(const vt_device *d, int which)
{
    return which >= 0 && which < VT_CNT_COUNT ? d->counters[which] : 0;
}

const char *vt_counter_name(int which)
{
    static const char *const names[VT_CNT_COUNT] = {
        "frames_ok", "bad_crc", "framing", "too_long", "bad_length", "unknown_type", "bad_value",
        "unsupported", "bad_channel", "bad_version", "ignored", "replies_dropped", "edges_dropped",
        "watchdog_trips"
    };
    return which >= 0 && which < VT_CNT_COUNT ? names[which] : NULL;
}
