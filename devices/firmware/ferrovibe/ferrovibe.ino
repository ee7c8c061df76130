// FerroVibe firmware (ESP32, Arduino-ESP32 core 3.x): a magnet in ferrofluid tilted by two
// solenoids, controlled over serial with the ViESTac device protocol v1
// (docs/device-protocol.md). All protocol and timing logic lives in the portable C core
// (../src, ../include, host-tested by `make test`); this sketch only moves bytes and turns the
// channel's output state into solenoid drive.
//
// Build: the core must sit in the sketch folder. Link (or copy, e.g. for the Arduino IDE) it:
//   cd devices/firmware/ferrovibe && ln -sf ../src/*.c ../include/*.h .
//   arduino-cli compile --fqbn esp32:esp32:esp32 .
//   arduino-cli upload  --fqbn esp32:esp32:esp32 -p /dev/ttyUSB0 .
// `make sketch-check` compile-checks this file on the host against test/arduino_stub.
#include <Arduino.h>
#include <esp_timer.h>
#include <math.h>

#include "viestac_arduino.h"

static const unsigned long BAUD = 115200;   // §0: 115200 8N1
static const uint8_t FB_PWM_PIN = 25;       // front/back solenoid: H-bridge enable (PWM) ...
static const uint8_t FB_DIR_PIN = 27;       // ... and direction (HIGH = toward the front)
static const uint8_t LR_PWM_PIN = 26;       // left/right solenoid: enable (PWM) ...
static const uint8_t LR_DIR_PIN = 14;       // ... and direction (HIGH = toward the right)
static const uint32_t SOLENOID_PWM_HZ = 20000;
static const uint8_t PWM_BITS = 10;
static const float PWM_FULL = (float)((1u << PWM_BITS) - 1);
static const float DEG_TO_RAD_F = 3.14159265f / 180.0f;

static vt_device dev;                       // the whole device state, no heap
static vt_edge out;                         // channel 0's output, as last reported by the core
static float shown_magnitude = -1.0f;       // what the solenoids show now
static uint16_t shown_direction;

// The tilt as a 2-D vector (thesis §4.1.1: 0° = front, 90° = right, 180° = back, 270° = left):
// cos → front/back solenoid, sin → left/right solenoid, the sign picks the H-bridge direction.
// One channel: the newest edge is its output state.
static void keep_edge(const vt_edge *e)
{
    out = *e;
}

static void drive(uint16_t direction_cdeg, float magnitude)
{
    float rad = (float)direction_cdeg / 100.0f * DEG_TO_RAD_F;
    float x = cosf(rad) * magnitude, y = sinf(rad) * magnitude;
    digitalWrite(FB_DIR_PIN, x >= 0.0f ? HIGH : LOW);
    digitalWrite(LR_DIR_PIN, y >= 0.0f ? HIGH : LOW);
    ledcWrite(FB_PWM_PIN, (uint32_t)(fabsf(x) * PWM_FULL + 0.5f));
    ledcWrite(LR_PWM_PIN, (uint32_t)(fabsf(y) * PWM_FULL + 0.5f));
}

// Tilt magnitude (0..1) to show at `now`. Without a pattern: the static tilt. With one, its gate
// switches the tilt (texture: tilt for P/2, flat for P/2, thesis §4.1.2); pulse and
// continuous also re-tilt at the carrier while the gate is on. The pattern's intensity scales
// the tilt; a pattern with no tilt set vibrates toward the current direction at full tilt.
static float magnitude_at(const vt_edge &s, uint64_t now)
{
    if (s.mode == VT_MODE_OFF)
        return s.magnitude / 100.0f;
    if (!s.gate)
        return 0.0f;
    if (s.carrier_hz && ((now * 2u * s.carrier_hz / 1000000u) & 1u))
        return 0.0f;                        // the flat half of a carrier period
    return (s.magnitude ? s.magnitude : 100) / 100.0f * (s.intensity / 100.0f);
}

void setup()
{
    Serial.begin(BAUD);
    vt_device_init(&dev, &vt_model_ferrovibe);
    out = vt_device_channel(&dev, 0)->last;
    pinMode(FB_DIR_PIN, OUTPUT);
    pinMode(LR_DIR_PIN, OUTPUT);
    ledcAttach(FB_PWM_PIN, SOLENOID_PWM_HZ, PWM_BITS);
    ledcAttach(LR_PWM_PIN, SOLENOID_PWM_HZ, PWM_BITS);
    drive(0, 0.0f);
}

void loop()
{
    // 64-bit µs since boot: no 71-minute wrap as with 32-bit micros().
    uint64_t now = (uint64_t)esp_timer_get_time();
    vt_serial_pump(&dev, now);

    vt_drain_edges(&dev, now, keep_edge);

    float m = magnitude_at(out, now);
    if (m != shown_magnitude || out.direction_cdeg != shown_direction) {
        drive(out.direction_cdeg, m);
        shown_magnitude = m;
        shown_direction = out.direction_cdeg;
    }
}
