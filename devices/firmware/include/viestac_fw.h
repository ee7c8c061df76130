/* viestac_fw.h: the device side of the ViESTac device protocol v1 (docs/device-protocol.md).
 *
 * Portable C99: no malloc, no I/O, no clock, no mutable globals. The caller owns a vt_device
 * (a static instance on the ESP32, a ctypes buffer of vt_device_sizeof() bytes on the host),
 * passes bytes in with the current time in microseconds, takes reply bytes out, and asks the
 * scheduler for the actuator edges that are due. Time is uint64_t µs everywhere (ESP32
 * esp_timer_get_time() is 64-bit; a 32-bit micros() wraps after 71 minutes) and must not go
 * backwards between calls.
 *
 *   loop: vt_device_receive(d, bytes, n, now)            -- frames are acted on at `now`
 *         vt_device_take_output(d, buf, cap)             -- IDENTIFY / PONG / ACK / ERROR bytes
 *         vt_device_advance(d, now, edges, max)          -- every output change with t <= now
 *         vt_device_next_edge_us(d)                      -- when to wake up next
 *
 * Watchdog (§2 SET_WATCHDOG): once armed, a device that gets no valid frame for its timeout
 * turns every actuator off by itself (edges with cause VT_CAUSE_WATCHDOG at the exact expiry
 * time) and tells the host with a WATCHDOG frame before its reply to the next frame. A host
 * that dies, hangs or loses the link cannot leave a vibration or a tilt running.
 */
#ifndef VIESTAC_FW_H
#define VIESTAC_FW_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#define VT_PROTOCOL_VERSION 1u
#define VT_MAX_WIRE 64u       /* bytes a receiver buffers before a delimiter (§1 Sizes, too_long) */
#define VT_MAX_DECODED 62u    /* body + CRC */
#define VT_MAX_BODY 60u
#define VT_MAX_PAYLOAD 58u
#define VT_MAX_CHANNELS 4u
#define VT_OUT_SIZE 256u      /* reply buffer; a full buffer drops the reply (counted) */
#define VT_EDGE_QUEUE 32u     /* command edges waiting for vt_device_advance */
#define VT_MAX_ON_OFF_US 60000000u
#define VT_NEVER UINT64_MAX   /* "no edge scheduled" */
#define VT_WATCHDOG_MIN_MS 10u
#define VT_WATCHDOG_MAX_MS 60000u
/* The watchdog at power-up, before any SET_WATCHDOG: 0 = off until a host arms it (a host that
 * predates SET_WATCHDOG keeps working unchanged). A rig whose hosts all speak it may build its
 * firmware with e.g. -DVT_WATCHDOG_BOOT_MS=1500 (3 of the host's 0.5 s PINGs) to be covered
 * from the first frame on. */
#ifndef VT_WATCHDOG_BOOT_MS
#define VT_WATCHDOG_BOOT_MS 0u
#endif

/* Message types (§2, §3). */
enum {
    VT_HELLO = 0x01, VT_PING = 0x02, VT_SET_WATCHDOG = 0x03, VT_SET_PATTERN = 0x10, VT_SET_TILT = 0x11,
    VT_SET_TEMPERATURE = 0x12, VT_SET_FRICTION = 0x13, VT_STOP = 0x1F,
    VT_IDENTIFY = 0x81, VT_PONG = 0x82, VT_ACK = 0x83, VT_ERROR = 0x84, VT_WATCHDOG = 0x85
};

/* ERROR codes (§3). too_long is reported with code 3, like bad_length (§1 table). */
enum {
    VT_ERR_NONE = 0, VT_ERR_BAD_CRC = 1, VT_ERR_FRAMING = 2, VT_ERR_BAD_LENGTH = 3,
    VT_ERR_UNKNOWN_TYPE = 4, VT_ERR_BAD_VALUE = 5, VT_ERR_UNSUPPORTED = 6,
    VT_ERR_BAD_CHANNEL = 7, VT_ERR_BAD_VERSION = 8
};

/* caps bits (§3); pattern mode m (1..3) needs bit m-1. */
enum {
    VT_CAP_PULSE = 1u << 0, VT_CAP_CONTINUOUS = 1u << 1, VT_CAP_TEXTURE = 1u << 2,
    VT_CAP_TILT = 1u << 3, VT_CAP_TEMPERATURE = 1u << 4, VT_CAP_FRICTION = 1u << 5
};

enum { VT_MODE_OFF = 0, VT_MODE_PULSE = 1, VT_MODE_CONTINUOUS = 2, VT_MODE_TEXTURE = 3 };
enum { VT_CAUSE_STATE = 0, VT_CAUSE_COMMAND = 1, VT_CAUSE_SCHEDULE = 2, VT_CAUSE_WATCHDOG = 3 };
#define VT_CHANNEL_ALL 0xFFu

/* ---- frames (vt_frame.c, §1) ------------------------------------------------------------ */

uint16_t vt_crc16(const uint8_t *data, size_t len);          /* CRC-16/CCITT-FALSE */
/* COBS without the delimiter; dst needs len + len/254 + 1 bytes. Returns the encoded length. */
size_t vt_cobs_encode(const uint8_t *src, size_t len, uint8_t *dst);
/* Returns 0 and the decoded length in *out_len, or -1 if src is not valid COBS or dst is too small. */
int vt_cobs_decode(const uint8_t *src, size_t len, uint8_t *dst, size_t cap, size_t *out_len);
/* The complete wire frame COBS(type seq payload crc) 0x00; returns its length, 0 if plen > 58
 * or cap < the frame (64 bytes always suffice). */
size_t vt_frame_encode(uint8_t type, uint8_t seq, const uint8_t *payload, size_t plen,
                       uint8_t *dst, size_t cap);

typedef struct {
    uint8_t type, seq, len;                /* len = payload length */
    uint8_t payload[VT_MAX_PAYLOAD];
} vt_frame;

typedef struct {
    uint8_t buf[VT_MAX_WIRE];
    uint8_t len;
    uint8_t discarding;                    /* after too_long: skip to the next 0x00 */
} vt_decoder;

/* vt_decoder_feed results */
enum { VT_DEC_NONE = 0, VT_DEC_FRAME, VT_DEC_FRAMING, VT_DEC_TOO_LONG, VT_DEC_BAD_LENGTH, VT_DEC_BAD_CRC };

void vt_decoder_init(vt_decoder *dec);
/* One byte in. VT_DEC_FRAME: *out holds a frame with a good CRC (type/payload not checked yet).
 * Errors are reported once per rejected frame; TOO_LONG when the 65th byte arrives. */
int vt_decoder_feed(vt_decoder *dec, uint8_t byte, vt_frame *out);
/* Type/length check of a decoded frame for any receiver: VT_ERR_NONE, VT_ERR_UNKNOWN_TYPE or
 * VT_ERR_BAD_LENGTH (§1: "payload length wrong for its type"). */
int vt_message_check(uint8_t type, const uint8_t *payload, size_t len);

/* ---- models (vt_models.c) ----------------------------------------------------------------- */

typedef struct {
    const char *name;                      /* 1..32 lower-case ASCII, as sent in IDENTIFY */
    uint8_t fw_major, fw_minor, fw_patch;
    uint8_t channels;                      /* 1..VT_MAX_CHANNELS */
    uint8_t caps;
    uint16_t carrier_hz;                   /* used when SET_PATTERN says carrier_hz = 0 */
} vt_model;

extern const vt_model vt_model_fingertac;
extern const vt_model vt_model_ferrovibe;
extern const vt_model vt_model_devkit;
const vt_model *vt_model_by_name(const char *name);  /* NULL if unknown */

/* ---- device (vt_device.c, vt_sched.c) ----------------------------------------------------- */

/* The output state of one channel after a change (what the actuator driver applies). */
typedef struct {
    uint64_t t_us;                         /* exact scheduled time, or the command's arrival */
    uint8_t channel;
    uint8_t gate;                          /* pattern gate: 1 = vibrating / tilted (texture) */
    uint8_t mode, intensity;
    uint16_t carrier_hz;                   /* effective carrier; 0 for texture and off */
    uint16_t direction_cdeg;               /* tilt layer */
    int16_t centi_celsius;                 /* temperature layer: 0 when off */
    uint16_t friction_milli;               /* friction layer: 0 when off */
    uint8_t magnitude;
    uint8_t temperature_on, friction_on;
    uint8_t cause;                         /* VT_CAUSE_* */
} vt_edge;

typedef struct {
    uint64_t next_us;                      /* next gate toggle, VT_NEVER if none */
    uint32_t on_us, off_us;                /* pattern layer, as received */
    uint16_t carrier_hz;
    uint16_t direction_cdeg;               /* tilt layer */
    int16_t centi_celsius;                 /* temperature layer (valid if temperature_on) */
    uint16_t friction_milli;               /* friction layer (valid if friction_on) */
    uint8_t mode, intensity;
    uint8_t phase_on;                      /* pulse/texture: in the on-phase */
    uint8_t magnitude;
    uint8_t temperature_on, friction_on;
    vt_edge last;                          /* output as last reported, to detect changes */
} vt_channel;

enum {
    VT_CNT_FRAMES_OK, VT_CNT_BAD_CRC, VT_CNT_FRAMING, VT_CNT_TOO_LONG, VT_CNT_BAD_LENGTH,
    VT_CNT_UNKNOWN_TYPE, VT_CNT_BAD_VALUE, VT_CNT_UNSUPPORTED, VT_CNT_BAD_CHANNEL,
    VT_CNT_BAD_VERSION, VT_CNT_IGNORED, VT_CNT_REPLIES_DROPPED, VT_CNT_EDGES_DROPPED,
    VT_CNT_WATCHDOG_TRIPS,
    VT_CNT_COUNT
};

typedef struct {
    const vt_model *model;
    vt_decoder dec;
    vt_channel ch[VT_MAX_CHANNELS];
    uint32_t counters[VT_CNT_COUNT];
    uint8_t tx_seq;
    uint16_t out_head, out_len;
    uint8_t out[VT_OUT_SIZE];
    uint8_t q_head, q_len;
    vt_edge q[VT_EDGE_QUEUE];
    uint32_t wd_ms;                        /* watchdog timeout, 0 = off */
    uint64_t wd_deadline_us;               /* when it trips, VT_NEVER while disarmed */
    uint8_t wd_host;                       /* a host set it: it understands WATCHDOG reports */
    uint8_t wd_report;                     /* tripped since the last report: tell the host */
} vt_device;

size_t vt_device_sizeof(void);
size_t vt_edge_sizeof(void);
size_t vt_channel_sizeof(void);
/* offsetof the k-th vt_edge field in declaration order, (size_t)-1 past the last: bindings that
 * mirror vt_edge check every field, since a reordered struct can keep its size. */
size_t vt_edge_offset(int k);
/* 0, or -1 (d untouched) if m is NULL or has 0 or more than VT_MAX_CHANNELS channels. */
int vt_device_init(vt_device *d, const vt_model *m);
/* Feed bytes from the host; complete frames take effect at now_us (§2 timing rule). */
void vt_device_receive(vt_device *d, const uint8_t *data, size_t len, uint64_t now_us);
/* Move up to cap pending reply bytes to dst; returns how many. */
size_t vt_device_take_output(vt_device *d, uint8_t *dst, size_t cap);
size_t vt_device_output_pending(const vt_device *d);
/* Write up to max edges with t <= now_us, in time order; call again while it returns max. */
size_t vt_device_advance(vt_device *d, uint64_t now_us, vt_edge *edges, size_t max);
uint64_t vt_device_next_edge_us(const vt_device *d);         /* VT_NEVER if none; includes the watchdog */
/* The watchdog timeout in ms (0 = off; else VT_WATCHDOG_MIN_MS..VT_WATCHDOG_MAX_MS), e.g. a
 * sketch's own power-up default; it arms at the next valid frame. Returns 0, or -1 (unchanged)
 * if out of range. */
int vt_device_set_watchdog(vt_device *d, uint32_t timeout_ms);
uint64_t vt_device_watchdog_deadline_us(const vt_device *d); /* VT_NEVER while disarmed */
const vt_channel *vt_device_channel(const vt_device *d, uint8_t channel);  /* NULL if out of range */
uint32_t vt_device_counter(const vt_device *d, int which);
const char *vt_counter_name(int which);                      /* NULL past the last */

/* Internal to the core (vt_sched.c, used by vt_device.c). */
void vt_sched_init(vt_device *d);
/* Fire every scheduled toggle with t <= now_us into the edge queue (before a command applies). */
void vt_sched_catch_up(vt_device *d, uint64_t now_us);
/* After a command changed channel i's layers at now_us: restart its pattern if asked, and queue
 * an edge (cause VT_CAUSE_COMMAND or VT_CAUSE_WATCHDOG) if its output changed. */
void vt_sched_commit(vt_device *d, uint8_t i, int restart, uint64_t now_us, uint8_t cause);
/* Trip the watchdog if it expired at or before now_us (vt_device.c). */
void vt_watchdog_check(vt_device *d, uint64_t now_us);

#ifdef __cplusplus
}
#endif
#endif /* VIESTAC_FW_H */
