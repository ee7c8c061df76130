/* Host unit tests of the firmware core: plain C, no framework. Exit code 0 = pass.
 * Built by `make test` with -fsanitize=address,undefined. */
#include <stdio.h>
#include <string.h>

#include "viestac_fw.h"

static int checks, failures;
#define CHECK(cond)                                                                        \
    do {                                                                                   \
        checks++;                                                                          \
        if (!(cond)) {                                                                     \
            failures++;                                                                    \
            fprintf(stderr, "%s:%d: CHECK(%s) failed\n", __FILE__, __LINE__, #cond);       \
        }                                                                                  \
    } while (0)

static uint32_t rng_state = 12345;
static uint8_t rnd8(void)
{
    rng_state = rng_state * 1103515245u + 12345u;   /* LCG: deterministic across platforms */
    return (uint8_t)(rng_state >> 16);
}

static void put16(uint8_t *p, uint16_t v) { p[0] = (uint8_t)v; p[1] = (uint8_t)(v >> 8); }
static void put32(uint8_t *p, uint32_t v) { put16(p, (uint16_t)v); put16(p + 2, (uint16_t)(v >> 16)); }

/* ---- helpers that talk to a device ---------------------------------------------------------- */

static void cmd(vt_device *d, uint8_t type, uint8_t seq, const uint8_t *p, size_t n, uint64_t now)
{
    uint8_t wire[VT_MAX_WIRE];
    size_t len = vt_frame_encode(type, seq, p, n, wire, sizeof wire);
    CHECK(len > 0);
    vt_device_receive(d, wire, len, now);
}

static void set_pattern(vt_device *d, uint8_t seq, uint8_t ch, uint8_t mode, uint8_t intensity,
                        uint16_t carrier, uint32_t on, uint32_t off, uint64_t now)
{
    uint8_t p[13] = { ch, mode, intensity };
    put16(p + 3, carrier);
    put32(p + 5, on);
    put32(p + 9, off);
    cmd(d, VT_SET_PATTERN, seq, p, sizeof p, now);
}

static void set_tilt(vt_device *d, uint8_t seq, uint8_t ch, uint16_t dir, uint8_t mag, uint64_t now)
{
    uint8_t p[4] = { ch, 0, 0, mag };
    put16(p + 1, dir);
    cmd(d, VT_SET_TILT, seq, p, sizeof p, now);
}

/* SET_TEMPERATURE (centi-degrees) or SET_FRICTION (milli): both are channel + 16-bit value. */
static void set_layer(vt_device *d, uint8_t type, uint8_t seq, uint8_t ch, uint16_t v, uint64_t now)
{
    uint8_t p[3] = { ch };
    put16(p + 1, v);
    cmd(d, type, seq, p, sizeof p, now);
}

/* Decode every pending reply; returns how many frames were found. */
static size_t replies(vt_device *d, vt_frame *frames, size_t max)
{
    uint8_t buf[VT_OUT_SIZE];
    size_t n = vt_device_take_output(d, buf, sizeof buf), count = 0;
    vt_decoder dec;
    vt_decoder_init(&dec);
    for (size_t i = 0; i < n; i++) {
        vt_frame f;
        int r = vt_decoder_feed(&dec, buf[i], &f);
        CHECK(r == VT_DEC_NONE || r == VT_DEC_FRAME);
        if (r == VT_DEC_FRAME && count < max)
            frames[count++] = f;
    }
    return count;
}

/* The single reply a command must produce: ACK (code 0) or ERROR code. */
static int reply_code(vt_device *d, uint8_t seq)
{
    vt_frame f[4];
    size_t n = replies(d, f, 4);
    CHECK(n == 1);
    if (n != 1)
        return -1;
    if (f[0].type == VT_ACK && f[0].len == 1 && f[0].payload[0] == seq)
        return 0;
    if (f[0].type == VT_ERROR && f[0].len == 2)
        return f[0].payload[1];
    return -1;
}

static size_t advance_all(vt_device *d, uint64_t now, vt_edge *edges, size_t max)
{
    return vt_device_advance(d, now, edges, max);
}

/* ---- tests ---------------------------------------------------------------------------------- */

static void test_crc(void)
{
    CHECK(vt_crc16((const uint8_t *)"123456789", 9) == 0x29B1);   /* §1 check value */
    CHECK(vt_crc16(NULL, 0) == 0xFFFF);
}

static void test_cobs(void)
{
    uint8_t out[300], back[300];
    size_t n;
    const uint8_t z[1] = { 0 };
    CHECK(vt_cobs_encode(z, 1, out) == 2 && out[0] == 1 && out[1] == 1);
    CHECK(vt_cobs_encode(z, 0, out) == 1 && out[0] == 1);
    const uint8_t a[4] = { 0x11, 0x22, 0x00, 0x33 };
    CHECK(vt_cobs_encode(a, 4, out) == 5 && memcmp(out, "\x03\x11\x22\x02\x33", 5) == 0);
    const uint8_t b[4] = { 0x11, 0x00, 0x00, 0x00 };
    CHECK(vt_cobs_encode(b, 4, out) == 5 && memcmp(out, "\x02\x11\x01\x01\x01", 5) == 0);

    uint8_t ones[255];
    memset(ones, 1, sizeof ones);
    CHECK(vt_cobs_encode(ones, 254, out) == 255 && out[0] == 0xFF);       /* no trailing 0x01 */
    CHECK(vt_cobs_decode(out, 255, back, sizeof back, &n) == 0 && n == 254);
    CHECK(vt_cobs_encode(ones, 255, out) == 257 && out[0] == 0xFF && out[255] == 2);
    CHECK(vt_cobs_decode(out, 257, back, sizeof back, &n) == 0 && n == 255 && memcmp(back, ones, 255) == 0);

    for (int trial = 0; trial < 500; trial++) {                 /* round trips with many zeros */
        uint8_t raw[100];
        size_t len = rnd8() % 100;
        for (size_t i = 0; i < len; i++)
            raw[i] = (rnd8() & 3) ? rnd8() : 0;
        size_t m = vt_cobs_encode(raw, len, out);
        CHECK(memchr(out, 0, m) == NULL);
        CHECK(vt_cobs_decode(out, m, back, sizeof back, &n) == 0 && n == len && memcmp(back, raw, len) == 0);
    }
    CHECK(vt_cobs_decode((const uint8_t *)"\x02", 1, back, sizeof back, &n) == -1);  /* points past the end */
    CHECK(vt_cobs_decode((const uint8_t *)"\x05\x11", 2, back, sizeof back, &n) == -1);
    CHECK(vt_cobs_decode((const uint8_t *)"\x03\x11\x22", 3, back, 1, &n) == -1);    /* dst too small */
}

static void test_frames(void)
{
    uint8_t payload[VT_MAX_PAYLOAD + 1], wire[VT_MAX_WIRE + 8];
    vt_decoder dec;
    vt_frame f;
    vt_decoder_init(&dec);
    for (size_t plen = 0; plen <= VT_MAX_PAYLOAD; plen++) {
        for (size_t i = 0; i < plen; i++)
            payload[i] = rnd8();
        size_t n = vt_frame_encode(0x10, (uint8_t)plen, payload, plen, wire, sizeof wire);
        CHECK(n >= 6 && n <= VT_MAX_WIRE && wire[n - 1] == 0 && memchr(wire, 0, n - 1) == NULL);
        int got = VT_DEC_NONE;
        for (size_t i = 0; i < n; i++) {
            got = vt_decoder_feed(&dec, wire[i], &f);
            CHECK(i == n - 1 || got == VT_DEC_NONE);
        }
        CHECK(got == VT_DEC_FRAME && f.type == 0x10 && f.seq == plen && f.len == plen &&
              memcmp(f.payload, payload, plen) == 0);
    }
    CHECK(vt_frame_encode(1, 0, payload, VT_MAX_PAYLOAD + 1, wire, sizeof wire) == 0);
    CHECK(vt_frame_encode(1, 0, payload, 1, wire, 5) == 0);

    /* §1 example body PING seq 0 token 0: check the CRC is appended little-endian */
    uint8_t body[6] = { 0x02, 0x00, 0, 0, 0, 0 };
    uint16_t crc = vt_crc16(body, 6);
    uint8_t raw[8], enc[10];
    memcpy(raw, body, 6);
    raw[6] = (uint8_t)crc;
    raw[7] = (uint8_t)(crc >> 8);
    size_t m = vt_cobs_encode(raw, 8, enc);
    CHECK(vt_frame_encode(0x02, 0, body + 2, 4, wire, sizeof wire) == m + 1 && memcmp(wire, enc, m) == 0);
}

static int feed_all(vt_decoder *dec, const uint8_t *bytes, size_t n, int *results, size_t max_results)
{
    vt_frame f;
    int count = 0;
    for (size_t i = 0; i < n; i++) {
        int r = vt_decoder_feed(dec, bytes[i], &f);
        if (r != VT_DEC_NONE && (size_t)count < max_results)
            results[count++] = r;
    }
    return count;
}

static void test_decoder_errors(void)
{
    vt_decoder dec;
    int res[8];
    uint8_t buf[200];
    vt_decoder_init(&dec);

    CHECK(feed_all(&dec, (const uint8_t *)"\0\0\0", 3, res, 8) == 0);          /* empty frames */
    CHECK(feed_all(&dec, (const uint8_t *)"\x05\x11\0", 3, res, 8) == 1 && res[0] == VT_DEC_FRAMING);
    CHECK(feed_all(&dec, (const uint8_t *)"\x02\xAA\0", 3, res, 8) == 1 && res[0] == VT_DEC_BAD_LENGTH);

    uint8_t wire[VT_MAX_WIRE];
    size_t n = vt_frame_encode(VT_PING, 1, (const uint8_t *)"\1\2\3\4", 4, wire, sizeof wire);
    wire[2] ^= 0x40;                                           /* flip a bit, no new zero */
    CHECK(feed_all(&dec, wire, n, res, 8) == 1 && res[0] == VT_DEC_BAD_CRC);

    /* 65 bytes before the delimiter: too_long once, at the 65th byte; resync at 0x00 */
    memset(buf, 0x42, 200);
    CHECK(feed_all(&dec, buf, 65, res, 8) == 1 && res[0] == VT_DEC_TOO_LONG);
    CHECK(feed_all(&dec, buf, 100, res, 8) == 0);
    CHECK(feed_all(&dec, (const uint8_t *)"\0", 1, res, 8) == 0);
    /* exactly 64 bytes is not too_long; it decodes to a 63-byte frame: bad_length */
    buf[0] = 64;                                               /* one valid 64-byte COBS block */
    memset(buf + 1, 0x42, 63);
    buf[64] = 0;
    CHECK(feed_all(&dec, buf, 65, res, 8) == 1 && res[0] == VT_DEC_BAD_LENGTH);

    /* garbage, then a valid frame right after a delimiter */
    n = vt_frame_encode(VT_PING, 7, (const uint8_t *)"\1\2\3\4", 4, wire, sizeof wire);
    CHECK(feed_all(&dec, (const uint8_t *)"\x13\x37\x99", 3, res, 8) == 0);
    CHECK(feed_all(&dec, (const uint8_t *)"\0", 1, res, 8) == 1);       /* the garbage itself */
    CHECK(feed_all(&dec, wire, n, res, 8) == 1 && res[0] == VT_DEC_FRAME);
}

static void test_message_check(void)
{
    uint8_t p[41] = { 0 };
    CHECK(vt_message_check(VT_HELLO, p, 1) == VT_ERR_NONE);
    CHECK(vt_message_check(VT_HELLO, p, 2) == VT_ERR_BAD_LENGTH);
    CHECK(vt_message_check(VT_SET_PATTERN, p, 13) == VT_ERR_NONE);
    CHECK(vt_message_check(VT_SET_PATTERN, p, 12) == VT_ERR_BAD_LENGTH);
    CHECK(vt_message_check(VT_STOP, p, 0) == VT_ERR_BAD_LENGTH);
    CHECK(vt_message_check(0x55, p, 0) == VT_ERR_UNKNOWN_TYPE);
    p[8] = 9;
    CHECK(vt_message_check(VT_IDENTIFY, p, 18) == VT_ERR_NONE);
    CHECK(vt_message_check(VT_IDENTIFY, p, 17) == VT_ERR_BAD_LENGTH);
    p[8] = 0;
    CHECK(vt_message_check(VT_IDENTIFY, p, 9) == VT_ERR_BAD_LENGTH);
}

static void test_models(void)
{
    CHECK(vt_model_by_name("fingertac") == &vt_model_fingertac);
    CHECK(vt_model_by_name("ferrovibe") == &vt_model_ferrovibe);
    CHECK(vt_model_by_name("FingerTac") == NULL && vt_model_by_name(NULL) == NULL);
    CHECK(vt_model_fingertac.channels == 2 && vt_model_fingertac.caps == 0x07 && vt_model_fingertac.carrier_hz == 235);
    CHECK(vt_model_ferrovibe.channels == 1 && vt_model_ferrovibe.caps == 0x0F && vt_model_ferrovibe.carrier_hz == 235);
    CHECK(vt_model_by_name("devkit") == &vt_model_devkit);
    CHECK(vt_model_devkit.channels == 1 && vt_model_devkit.caps == 0x37 && vt_model_devkit.carrier_hz == 235);
    vt_device d;
    vt_model bad = vt_model_fingertac;
    bad.channels = VT_MAX_CHANNELS + 1;
    CHECK(vt_device_init(&d, &bad) == -1 && vt_device_init(&d, NULL) == -1);
}

static void test_hello_ping(void)
{
    vt_device d;
    vt_frame f[4];
    CHECK(vt_device_init(&d, &vt_model_fingertac) == 0);
    cmd(&d, VT_HELLO, 9, (const uint8_t *)"\1", 1, 0);
    CHECK(replies(&d, f, 4) == 1);
    const uint8_t want[] = { 1, 1, 0, 0, 2, 0x07, 235, 0, 9, 'f', 'i', 'n', 'g', 'e', 'r', 't', 'a', 'c' };
    CHECK(f[0].type == VT_IDENTIFY && f[0].seq == 0 && f[0].len == sizeof want && memcmp(f[0].payload, want, sizeof want) == 0);

    cmd(&d, VT_PING, 10, (const uint8_t *)"\x78\x56\x34\x12", 4, 0);
    CHECK(replies(&d, f, 4) == 1);
    CHECK(f[0].type == VT_PONG && f[0].seq == 1 && f[0].len == 4 && memcmp(f[0].payload, "\x78\x56\x34\x12", 4) == 0);

    cmd(&d, VT_HELLO, 11, (const uint8_t *)"\2", 1, 0);            /* §6 bad_version */
    CHECK(reply_code(&d, 11) == VT_ERR_BAD_VERSION && vt_device_counter(&d, VT_CNT_BAD_VERSION) == 1);
    cmd(&d, 0x55, 12, NULL, 0, 0);
    CHECK(replies(&d, f, 4) == 1 && f[0].type == VT_ERROR && f[0].payload[0] == 12 && f[0].payload[1] == VT_ERR_UNKNOWN_TYPE);
    cmd(&d, VT_SET_TILT, 13, (const uint8_t *)"\0\0\0", 3, 0);     /* payload one byte short */
    CHECK(replies(&d, f, 4) == 1 && f[0].type == VT_ERROR && f[0].payload[0] == 0xFF && f[0].payload[1] == VT_ERR_BAD_LENGTH);
    cmd(&d, VT_ACK, 14, (const uint8_t *)"\1", 1, 0);              /* a device frame: ignored */
    CHECK(replies(&d, f, 4) == 0 && vt_device_counter(&d, VT_CNT_IGNORED) == 1);
    CHECK(vt_device_counter(&d, VT_CNT_FRAMES_OK) == 4);
    CHECK(strcmp(vt_counter_name(VT_CNT_TOO_LONG), "too_long") == 0 && vt_counter_name(VT_CNT_COUNT) == NULL);
}

static void test_pulse_train(void)
{
    vt_device d;
    vt_edge e[32];
    vt_device_init(&d, &vt_model_fingertac);
    CHECK(vt_device_next_edge_us(&d) == VT_NEVER);
    set_pattern(&d, 1, 0, VT_MODE_PULSE, 100, 0, 50000, 200000, 1000);
    CHECK(reply_code(&d, 1) == 0);
    CHECK(vt_device_next_edge_us(&d) == 1000);                     /* the command edge, queued */
    size_t n = advance_all(&d, 1000000, e, 32);
    const uint64_t t[] = { 1000, 51000, 251000, 301000, 501000, 551000, 751000, 801000 };
    CHECK(n == 8);
    for (size_t i = 0; i < n && i < 8; i++) {
        CHECK(e[i].t_us == t[i] && e[i].channel == 0 && e[i].gate == (i % 2 == 0));
        CHECK(e[i].mode == VT_MODE_PULSE && e[i].intensity == 100 && e[i].carrier_hz == 235);
        CHECK(e[i].cause == (i == 0 ? VT_CAUSE_COMMAND : VT_CAUSE_SCHEDULE));
    }
    CHECK(vt_device_next_edge_us(&d) == 1001000);

    /* the same pattern again: nothing changes, the phase goes on */
    set_pattern(&d, 2, 0, VT_MODE_PULSE, 100, 0, 50000, 200000, 1010000);
    CHECK(reply_code(&d, 2) == 0);
    CHECK(advance_all(&d, 1010000, e, 32) == 1 && e[0].t_us == 1001000 && e[0].gate == 1);
    CHECK(vt_device_next_edge_us(&d) == 1051000);
    /* a different one restarts with the on-phase at reception (here: still on, so no edge) */
    set_pattern(&d, 3, 0, VT_MODE_PULSE, 100, 0, 30000, 100000, 1020000);
    CHECK(reply_code(&d, 3) == 0);
    CHECK(advance_all(&d, 1020000, e, 32) == 0);
    CHECK(vt_device_next_edge_us(&d) == 1050000);
    /* a change of intensity is an output change: a command edge */
    set_pattern(&d, 4, 0, VT_MODE_PULSE, 50, 300, 30000, 100000, 1030000);
    CHECK(reply_code(&d, 4) == 0);
    CHECK(advance_all(&d, 1030000, e, 32) == 1 && e[0].cause == VT_CAUSE_COMMAND && e[0].intensity == 50 && e[0].carrier_hz == 300);
    CHECK(vt_device_next_edge_us(&d) == 1060000);

    /* advance with max = 1 hands out the same edges one by one */
    uint64_t last = 0;
    for (int i = 0; i < 10; i++) {
        CHECK(vt_device_advance(&d, 2000000, e, 1) == 1);
        CHECK(e[0].t_us > last);
        last = e[0].t_us;
    }

    /* STOP: gate off, nothing scheduled */
    cmd(&d, VT_STOP, 5, (const uint8_t *)"\xFF", 1, 2000000);
    CHECK(reply_code(&d, 5) == 0);
    n = advance_all(&d, 3000000, e, 32);
    CHECK(n >= 1 && e[n - 1].t_us == 2000000 && e[n - 1].gate == 0 && e[n - 1].mode == VT_MODE_OFF);
    CHECK(vt_device_next_edge_us(&d) == VT_NEVER);
}

static void test_modes(void)
{
    vt_device d;
    vt_edge e[32];
    vt_device_init(&d, &vt_model_fingertac);
    set_pattern(&d, 1, 0xFF, VT_MODE_CONTINUOUS, 80, 0, 0, 0, 10);     /* both channels */
    CHECK(reply_code(&d, 1) == 0);
    CHECK(advance_all(&d, 1000000, e, 32) == 2 && e[0].channel == 0 && e[1].channel == 1 && e[0].gate && e[1].gate);
    set_pattern(&d, 2, 1, VT_MODE_PULSE, 80, 0, 0, 1000, 20);           /* on_us = 0: always off */
    CHECK(reply_code(&d, 2) == 0);
    CHECK(advance_all(&d, 1000000, e, 32) == 1 && e[0].gate == 0 && vt_device_next_edge_us(&d) == VT_NEVER);
    set_pattern(&d, 3, 1, VT_MODE_PULSE, 80, 0, 1000, 0, 30);           /* off_us = 0: always on */
    CHECK(reply_code(&d, 3) == 0);
    CHECK(advance_all(&d, 1000000, e, 32) == 1 && e[0].gate == 1 && vt_device_next_edge_us(&d) == VT_NEVER);

    /* texture, period 4000 µs: rising edges 4000 apart, on for 2000, no carrier */
    set_pattern(&d, 4, 0, VT_MODE_TEXTURE, 100, 0, 2000, 2000, 100000);
    CHECK(reply_code(&d, 4) == 0);
    size_t n = advance_all(&d, 120000, e, 32);
    CHECK(n == 11);
    for (size_t i = 0; i < n; i++)
        CHECK(e[i].t_us == 100000 + 2000 * i && e[i].gate == (i % 2 == 0) && e[i].carrier_hz == 0);

    /* errors change nothing */
    uint64_t next = vt_device_next_edge_us(&d);
    set_pattern(&d, 5, 2, VT_MODE_PULSE, 100, 0, 1, 1, 120000);
    CHECK(reply_code(&d, 5) == VT_ERR_BAD_CHANNEL);
    set_pattern(&d, 6, 0, 4, 100, 0, 1, 1, 120000);
    CHECK(reply_code(&d, 6) == VT_ERR_BAD_VALUE);
    set_pattern(&d, 7, 0, VT_MODE_PULSE, 101, 0, 1, 1, 120000);
    CHECK(reply_code(&d, 7) == VT_ERR_BAD_VALUE);
    set_pattern(&d, 8, 0, VT_MODE_PULSE, 100, 0, VT_MAX_ON_OFF_US + 1, 1, 120000);
    CHECK(reply_code(&d, 8) == VT_ERR_BAD_VALUE);
    set_tilt(&d, 9, 0, 9000, 100, 120000);
    CHECK(reply_code(&d, 9) == VT_ERR_UNSUPPORTED);
    cmd(&d, VT_SET_TEMPERATURE, 10, (const uint8_t *)"\0\x10\x0e", 3, 120000);
    CHECK(reply_code(&d, 10) == VT_ERR_UNSUPPORTED);
    CHECK(advance_all(&d, 120000, e, 32) == 0 && vt_device_next_edge_us(&d) == next);
    CHECK(vt_device_counter(&d, VT_CNT_BAD_VALUE) == 3 && vt_device_counter(&d, VT_CNT_UNSUPPORTED) == 2 &&
          vt_device_counter(&d, VT_CNT_BAD_CHANNEL) == 1);
}

static void test_tilt(void)
{
    vt_device d;
    vt_edge e[64];
    vt_model all = vt_model_ferrovibe;
    all.caps = 0x3F;
    vt_device_init(&d, &all);
    set_pattern(&d, 1, 0, VT_MODE_TEXTURE, 100, 0, 1500, 1500, 0);
    CHECK(reply_code(&d, 1) == 0);
    CHECK(advance_all(&d, 0, e, 64) == 1);
    /* no advance for a while: the tilt command must come after the edges that were due */
    set_tilt(&d, 2, 0, 9000, 100, 10000);
    CHECK(reply_code(&d, 2) == 0);
    size_t n = advance_all(&d, 10000, e, 64);
    CHECK(n == 7 && e[6].cause == VT_CAUSE_COMMAND && e[6].t_us == 10000 && e[6].direction_cdeg == 9000 && e[6].magnitude == 100);
    for (size_t i = 1; i < n; i++)
        CHECK(e[i].t_us >= e[i - 1].t_us);
    CHECK(vt_device_next_edge_us(&d) == 10500);                        /* phase untouched */
    set_tilt(&d, 3, 0, 36000, 100, 10000);
    CHECK(reply_code(&d, 3) == VT_ERR_BAD_VALUE);
    set_tilt(&d, 4, 0, 0, 101, 10000);
    CHECK(reply_code(&d, 4) == VT_ERR_BAD_VALUE);
    cmd(&d, VT_SET_TEMPERATURE, 5, (const uint8_t *)"\0\x88\x13", 3, 10000);   /* 5000 = 50 °C */
    CHECK(reply_code(&d, 5) == 0 && vt_device_channel(&d, 0)->temperature_on && vt_device_channel(&d, 0)->centi_celsius == 5000);
    cmd(&d, VT_SET_TEMPERATURE, 6, (const uint8_t *)"\0\xFF\xFF", 3, 10000);   /* -1 */
    CHECK(reply_code(&d, 6) == VT_ERR_BAD_VALUE);
    cmd(&d, VT_SET_FRICTION, 7, (const uint8_t *)"\0\xF4\x01", 3, 10000);
    CHECK(reply_code(&d, 7) == 0 && vt_device_channel(&d, 0)->friction_milli == 500);
    cmd(&d, VT_STOP, 8, (const uint8_t *)"\0", 1, 10000);
    CHECK(reply_code(&d, 8) == 0);
    const vt_channel *c = vt_device_channel(&d, 0);
    CHECK(c->magnitude == 0 && c->mode == VT_MODE_OFF && !c->temperature_on && !c->friction_on);
    CHECK(vt_device_channel(&d, 1) == NULL);

    /* more command edges than the queue holds, without advancing: counted, state still right */
    vt_device_init(&d, &vt_model_ferrovibe);
    for (int i = 0; i < 40; i++) {
        uint8_t sink[VT_OUT_SIZE];
        set_tilt(&d, (uint8_t)i, 0, (uint16_t)(i * 100), 50, 100);
        vt_device_take_output(&d, sink, sizeof sink);
    }
    CHECK(vt_device_counter(&d, VT_CNT_EDGES_DROPPED) == 40 - VT_EDGE_QUEUE);
    CHECK(vt_device_counter(&d, VT_CNT_REPLIES_DROPPED) == 0);
    CHECK(vt_device_channel(&d, 0)->direction_cdeg == 3900);
}

static void test_temperature_friction(void)
{
    vt_device d;
    vt_edge e[32];
    vt_device_init(&d, &vt_model_devkit);
    set_pattern(&d, 1, 0, VT_MODE_PULSE, 100, 0, 50000, 200000, 0);
    CHECK(reply_code(&d, 1) == 0 && advance_all(&d, 0, e, 32) == 1 && !e[0].temperature_on && !e[0].friction_on);

    /* a command edge that keeps the pattern and its phase, after the toggles that were due */
    set_layer(&d, VT_SET_TEMPERATURE, 2, 0, 4000, 60000);
    CHECK(reply_code(&d, 2) == 0);
    CHECK(advance_all(&d, 60000, e, 32) == 2 && e[0].t_us == 50000 && e[0].cause == VT_CAUSE_SCHEDULE);
    CHECK(e[1].t_us == 60000 && e[1].cause == VT_CAUSE_COMMAND && e[1].temperature_on && e[1].centi_celsius == 4000);
    CHECK(!e[1].friction_on && e[1].gate == 0 && e[1].mode == VT_MODE_PULSE && e[1].carrier_hz == 235);
    CHECK(vt_device_next_edge_us(&d) == 250000);

    set_layer(&d, VT_SET_TEMPERATURE, 3, 0, 4000, 70000);             /* unchanged: no edge */
    CHECK(reply_code(&d, 3) == 0 && advance_all(&d, 70000, e, 32) == 0);
    set_layer(&d, VT_SET_FRICTION, 4, VT_CHANNEL_ALL, 800, 80000);
    CHECK(reply_code(&d, 4) == 0 && advance_all(&d, 80000, e, 32) == 1);
    CHECK(e[0].friction_on && e[0].friction_milli == 800 && e[0].temperature_on && e[0].centi_celsius == 4000);
    set_layer(&d, VT_SET_FRICTION, 5, 0, 800, 90000);
    CHECK(reply_code(&d, 5) == 0 && advance_all(&d, 90000, e, 32) == 0);
    set_layer(&d, VT_SET_FRICTION, 6, 0, 5001, 90000);                 /* an error changes nothing */
    CHECK(reply_code(&d, 6) == VT_ERR_BAD_VALUE && advance_all(&d, 90000, e, 32) == 0);
    set_layer(&d, VT_SET_TEMPERATURE, 7, 1, 3000, 90000);
    CHECK(reply_code(&d, 7) == VT_ERR_BAD_CHANNEL && advance_all(&d, 90000, e, 32) == 0);

    /* STOP: every layer off in one edge, values reported as 0; a second STOP changes nothing */
    cmd(&d, VT_STOP, 8, (const uint8_t *)"\0", 1, 100000);
    CHECK(reply_code(&d, 8) == 0 && advance_all(&d, 100000, e, 32) == 1);
    CHECK(e[0].mode == VT_MODE_OFF && !e[0].temperature_on && e[0].centi_celsius == 0 &&
          !e[0].friction_on && e[0].friction_milli == 0);
    CHECK(vt_device_channel(&d, 0)->centi_celsius == 4000);             /* the layer keeps its value */
    cmd(&d, VT_STOP, 9, (const uint8_t *)"\0", 1, 110000);
    CHECK(reply_code(&d, 9) == 0 && advance_all(&d, 110000, e, 32) == 0);

    /* 0 °C and friction 0 are values, not "off" */
    set_layer(&d, VT_SET_TEMPERATURE, 10, 0, 0, 120000);
    set_layer(&d, VT_SET_FRICTION, 11, 0, 0, 120000);
    vt_frame f[4];
    CHECK(replies(&d, f, 4) == 2 && f[0].type == VT_ACK && f[1].type == VT_ACK);
    CHECK(advance_all(&d, 120000, e, 32) == 2 && e[0].temperature_on && !e[0].friction_on &&
          e[1].temperature_on && e[1].friction_on && e[1].friction_milli == 0);
}

static void test_edge_layout(void)
{
    CHECK(vt_edge_sizeof() == sizeof(vt_edge) && sizeof(vt_edge) == 24);     /* no padding holes */
    CHECK(vt_edge_offset(0) == 0 && vt_edge_offset(7) == offsetof(vt_edge, centi_celsius));
    CHECK(vt_edge_offset(12) == offsetof(vt_edge, cause) && vt_edge_offset(13) == (size_t)-1);
    CHECK(vt_edge_offset(-1) == (size_t)-1);
}

static void test_output_overflow(void)
{
    vt_device d;
    vt_frame f[64];
    vt_device_init(&d, &vt_model_fingertac);
    for (int i = 0; i < 40; i++)                                    /* 40 PONGs x 10 bytes > 256 */
        cmd(&d, VT_PING, (uint8_t)i, (const uint8_t *)"\1\1\1\1", 4, 0);
    CHECK(vt_device_output_pending(&d) == 250);
    CHECK(vt_device_counter(&d, VT_CNT_REPLIES_DROPPED) == 15);
    size_t n = replies(&d, f, 64);
    CHECK(n == 25);
    for (size_t i = 0; i < n; i++)
        CHECK(f[i].type == VT_PONG && f[i].seq == i);                /* dropped replies use no seq */
}

static void test_garbage(void)
{
    vt_device d;
    vt_edge e[64];
    uint8_t junk[97];
    vt_device_init(&d, &vt_model_ferrovibe);
    uint64_t now = 0;
    for (int round = 0; round < 2000; round++) {
        size_t n = 1 + rnd8() % sizeof junk;
        for (size_t i = 0; i < n; i++)
            junk[i] = (rnd8() % 8 == 0) ? 0 : rnd8();
        now += 100;
        vt_device_receive(&d, junk, n, now);
        uint8_t sink[VT_OUT_SIZE];
        vt_device_take_output(&d, sink, sizeof sink);
        while (vt_device_advance(&d, now, e, 64) == 64) {
        }
    }
    uint32_t rejected = 0;
    for (int i = VT_CNT_BAD_CRC; i <= VT_CNT_UNKNOWN_TYPE; i++)
        rejected += vt_device_counter(&d, i);
    CHECK(rejected > 1000);
    /* a flush, then a valid frame, is understood */
    vt_device_receive(&d, (const uint8_t *)"\0", 1, now);
    vt_frame f[4];
    replies(&d, f, 4);
    cmd(&d, VT_PING, 77, (const uint8_t *)"\xAA\xBB\xCC\xDD", 4, now);
    CHECK(replies(&d, f, 4) == 1 && f[0].type == VT_PONG && memcmp(f[0].payload, "\xAA\xBB\xCC\xDD", 4) == 0);
}

static void set_watchdog(vt_device *d, uint8_t seq, uint16_t ms, uint64_t now)
{
    uint8_t p[2];
    put16(p, ms);
    cmd(d, VT_SET_WATCHDOG, seq, p, sizeof p, now);
}

/* §2 SET_WATCHDOG: no valid frame for the timeout -> every layer off at the expiry time itself,
 * reported before the reply to the next frame; any valid host frame feeds it. */
static void test_watchdog(void)
{
    vt_device d;
    vt_edge e[64];
    vt_frame f[4];
    vt_device_init(&d, &vt_model_ferrovibe);
    set_tilt(&d, 0, 0, 9000, 100, 1000);
    replies(&d, f, 4);
    CHECK(vt_device_watchdog_deadline_us(&d) == VT_NEVER);   /* off until a host arms it */
    CHECK(vt_device_advance(&d, 10000000, e, 64) == 1 && e[0].cause == VT_CAUSE_COMMAND);
    CHECK(vt_device_advance(&d, 20000000, e, 64) == 0);         /* the tilt stays: no watchdog yet */

    set_watchdog(&d, 1, 50, 20000000);
    CHECK(replies(&d, f, 4) == 1 && f[0].type == VT_ACK && f[0].payload[0] == 1);
    CHECK(vt_device_watchdog_deadline_us(&d) == 20050000 && vt_device_next_edge_us(&d) == 20050000);
    cmd(&d, VT_PING, 2, (const uint8_t *)"\1\2\3\4", 4, 20040000);   /* any valid frame feeds it */
    CHECK(vt_device_watchdog_deadline_us(&d) == 20090000);
    vt_device_receive(&d, (const uint8_t *)"\x05\x11\x00", 3, 20080000); /* a bad frame does not */
    CHECK(vt_device_watchdog_deadline_us(&d) == 20090000);
    uint8_t looped[VT_MAX_WIRE];
    size_t n = vt_frame_encode(VT_ACK, 0, (const uint8_t *)"\0", 1, looped, sizeof looped);
    vt_device_receive(&d, looped, n, 20085000);                  /* nor a device frame looped back */
    CHECK(vt_device_watchdog_deadline_us(&d) == 20090000);
    replies(&d, f, 4);
    CHECK(vt_device_advance(&d, 20089999, e, 64) == 0);
    CHECK(vt_device_advance(&d, 20100000, e, 64) == 1);
    CHECK(e[0].t_us == 20090000 && e[0].cause == VT_CAUSE_WATCHDOG && e[0].magnitude == 0 && e[0].gate == 0);
    CHECK(e[0].direction_cdeg == 9000);                          /* like STOP: flat, direction kept */
    CHECK(vt_device_counter(&d, VT_CNT_WATCHDOG_TRIPS) == 1 && vt_device_watchdog_deadline_us(&d) == VT_NEVER);
    CHECK(vt_device_advance(&d, 30000000, e, 64) == 0);         /* one trip per silence */
    CHECK(replies(&d, f, 4) == 0);                               /* the device speaks only when spoken to */

    cmd(&d, VT_PING, 3, (const uint8_t *)"\1\2\3\4", 4, 30000000);
    CHECK(replies(&d, f, 4) == 2 && f[0].type == VT_WATCHDOG && f[1].type == VT_PONG);
    CHECK(f[0].len == 4 && f[0].payload[0] == 50 && f[0].payload[1] == 0 && f[0].payload[2] == 1 && f[0].payload[3] == 0);
    cmd(&d, VT_PING, 4, (const uint8_t *)"\1\2\3\4", 4, 30001000);
    CHECK(replies(&d, f, 4) == 1 && f[0].type == VT_PONG);      /* reported once */

    /* a running pulse train: its toggles before the expiry come first, then everything off */
    vt_device_init(&d, &vt_model_fingertac);
    set_watchdog(&d, 0, 10, 0);
    set_pattern(&d, 1, 0, VT_MODE_PULSE, 100, 0, 3000, 2500, 0);
    replies(&d, f, 4);
    size_t k = vt_device_advance(&d, 50000, e, 64);
    CHECK(k == 5);                                               /* on@0, off@3000, on@5500, off@8500, wd@10000 */
    CHECK(e[k - 1].t_us == 10000 && e[k - 1].cause == VT_CAUSE_WATCHDOG && e[k - 1].mode == VT_MODE_OFF);
    CHECK(e[k - 2].t_us == 8500 && e[k - 2].cause == VT_CAUSE_SCHEDULE);
    CHECK(vt_device_next_edge_us(&d) == VT_NEVER);
    /* a frame that arrives after the expiry: the trip happened first, then the frame acts */
    set_tilt(&d, 2, 0, 9000, 100, 60000);                        /* unsupported on a FingerTac: ERROR */
    CHECK(replies(&d, f, 4) == 2 && f[0].type == VT_WATCHDOG && f[1].type == VT_ERROR);

    /* ranges: below 10 ms or above 60 s is bad_value and changes nothing; 0 turns it off */
    vt_device_init(&d, &vt_model_ferrovibe);
    set_watchdog(&d, 5, 9, 0);
    CHECK(replies(&d, f, 4) == 1 && f[0].type == VT_ERROR && f[0].payload[1] == VT_ERR_BAD_VALUE);
    CHECK(vt_device_watchdog_deadline_us(&d) == VT_NEVER);
    set_watchdog(&d, 6, 60001, 0);
    CHECK(replies(&d, f, 4) == 1 && f[0].type == VT_ERROR);
    set_watchdog(&d, 7, 100, 0);
    set_watchdog(&d, 8, 0, 1000);
    CHECK(replies(&d, f, 4) == 2 && f[1].type == VT_ACK && vt_device_watchdog_deadline_us(&d) == VT_NEVER);

    /* a sketch's power-up default arms at the first valid frame; its trips are not reported to a
     * host that never set the watchdog (an older host would not know the message) */
    vt_device_init(&d, &vt_model_ferrovibe);
    CHECK(vt_device_set_watchdog(&d, 5) == -1 && vt_device_set_watchdog(&d, 100) == 0);
    CHECK(vt_device_watchdog_deadline_us(&d) == VT_NEVER);
    set_tilt(&d, 0, 0, 4500, 80, 1000);
    CHECK(vt_device_watchdog_deadline_us(&d) == 101000);
    CHECK(vt_device_advance(&d, 200000, e, 64) == 2 && e[1].cause == VT_CAUSE_WATCHDOG && e[1].magnitude == 0);
    replies(&d, f, 4);
    cmd(&d, VT_PING, 1, (const uint8_t *)"\1\2\3\4", 4, 300000);
    CHECK(replies(&d, f, 4) == 1 && f[0].type == VT_PONG);
}

int main(void)
{
    test_crc();
    test_cobs();
    test_frames();
    test_decoder_errors();
    test_message_check();
    test_models();
    test_hello_ping();
    test_pulse_train();
    test_modes();
    test_tilt();
    test_temperature_friction();
    test_edge_layout();
    test_output_overflow();
    test_garbage();
    test_watchdog();
    printf("test_core: %d checks, %d failed\n", checks, failures);
    return failures ? 1 : 0;
}
