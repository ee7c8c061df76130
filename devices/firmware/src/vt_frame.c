/* Framing (docs/device-protocol.md §1): COBS(body ‖ crc16 LE) ‖ 0x00. */
#include <string.h>

#include "viestac_fw.h"

uint16_t vt_crc16(const uint8_t *data, size_t len)
{
    /* CRC-16/CCITT-FALSE: poly 0x1021, init 0xFFFF, no reflection, no final XOR. Bitwise, so
     * the core needs no table; 60 bytes cost a few µs on an ESP32. */
    uint16_t crc = 0xFFFF;
    while (len--) {
        crc ^= (uint16_t)(*data++ << 8);
        for (int i = 0; i < 8; i++)
            crc = (crc & 0x8000) ? (uint16_t)((crc << 1) ^ 0x1021) : (uint16_t)(crc << 1);
    }
    return crc;
}

size_t vt_cobs_encode(const uint8_t *src, size_t len, uint8_t *dst)
{
    size_t code_at = 0, out = 1;
    uint8_t code = 1;
    for (size_t i = 0; i < len; i++) {
        if (src[i] != 0) {
            dst[out++] = src[i];
            code++;
        }
        /* A zero ends a block; so do 254 data bytes (code 0xFF, no implied zero), but only if
         * more input follows: the minimal form, same as Python's `cobs` package. */
        if (src[i] == 0 || (code == 0xFF && i + 1 < len)) {
            dst[code_at] = code;
            code_at = out++;
            code = 1;
        }
    }
    dst[code_at] = code;
    return out;
}

int vt_cobs_decode(const uint8_t *src, size_t len, uint8_t *dst, size_t cap, size_t *out_len)
{
    size_t i = 0, out = 0;
    while (i < len) {
        uint8_t code = src[i];
        if (code == 0 || i + code > len)       /* "a code byte points past the end" (§1 framing) */
            return -1;
        for (size_t j = 1; j < code; j++) {
            if (src[i + j] == 0 || out >= cap)
                return -1;
            dst[out++] = src[i + j];
        }
        i += code;
        if (code != 0xFF && i < len) {
            if (out >= cap)
                return -1;
            dst[out++] = 0;
        }
    }
    *out_len = out;
    return 0;
}

size_t vt_frame_encode(uint8_t type, uint8_t seq, const uint8_t *payload, size_t plen,
                       uint8_t *dst, size_t cap)
{
    uint8_t raw[VT_MAX_DECODED];
    if (plen > VT_MAX_PAYLOAD)
        return 0;
    raw[0] = type;
    raw[1] = seq;
    if (plen)
        memcpy(raw + 2, payload, plen);
    uint16_t crc = vt_crc16(raw, plen + 2);
    raw[plen + 2] = (uint8_t)(crc & 0xFF);   /* little-endian (§1) */
    raw[plen + 3] = (uint8_t)(crc >> 8);
    size_t n = plen + 4;
    if (cap < n + n / 254 + 2)
        return 0;
    size_t m = vt_cobs_encode(raw, n, dst);
    dst[m] = 0x00;
    return m + 1;
}

void vt_decoder_init(vt_decoder *dec)
{
    memset(dec, 0, sizeof *dec);
}

int vt_decoder_feed(vt_decoder *dec, uint8_t byte, vt_frame *out)
{
    if (byte != 0) {
        if (dec->discarding)
            return VT_DEC_NONE;
        if (dec->len == VT_MAX_WIRE) {         /* more than 64 bytes before a delimiter */
            dec->discarding = 1;
            dec->len = 0;
            return VT_DEC_TOO_LONG;
        }
        dec->buf[dec->len++] = byte;
        return VT_DEC_NONE;
    }
    size_t n = dec->len;
    dec->len = 0;
    if (dec->discarding) {                     /* resynchronised */
        dec->discarding = 0;
        return VT_DEC_NONE;
    }
    if (n == 0)                                /* empty frame: a flush, not an error (§1) */
        return VT_DEC_NONE;
    uint8_t raw[VT_MAX_WIRE];
    size_t m;
    if (vt_cobs_decode(dec->buf, n, raw, sizeof raw, &m) != 0)
        return VT_DEC_FRAMING;
    if (m < 4 || m > VT_MAX_DECODED)
        return VT_DEC_BAD_LENGTH;
    uint16_t crc = (uint16_t)(raw[m - 2] | (raw[m - 1] << 8));
    if (vt_crc16(raw, m - 2) != crc)
        return VT_DEC_BAD_CRC;
    out->type = raw[0];
    out->seq = raw[1];
    out->len = (uint8_t)(m - 4);
    memcpy(out->payload, raw + 2, m - 4);
    return VT_DEC_FRAME;
}

int vt_message_check(uint8_t type, const uint8_t *payload, size_t len)
{
    size_t want;
    switch (type) {
    case VT_HELLO: want = 1; break;
    case VT_PING: want = 4; break;
    case VT_SET_WATCHDOG: want = 2; break;
    case VT_SET_PATTERN: want = 13; break;
    case VT_SET_TILT: want = 4; break;
    case VT_SET_TEMPERATURE: want = 3; break;
    case VT_SET_FRICTION: want = 3; break;
    case VT_STOP: want = 1; break;
    case VT_PONG: want = 4; break;
    case VT_ACK: want = 1; break;
    case VT_ERROR: want = 2; break;
    case VT_WATCHDOG: want = 4; break;
    case VT_IDENTIFY:                          /* 9 fixed bytes + model_len (1..32) characters */
        if (len < 10 || payload[8] < 1 || payload[8] > 32)
            return VT_ERR_BAD_LENGTH;
        want = 9u + payload[8];
        break;
    default:
        return VT_ERR_UNKNOWN_TYPE;
    }
    return len == want ? VT_ERR_NONE : VT_ERR_BAD_LENGTH;
}
