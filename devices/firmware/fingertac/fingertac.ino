// FingerTac firmware (ESP32, Arduino-ESP32 core 3.x): two LRAs driven by LEDC PWM at their
// 235 Hz resonance, controlled over serial with the ViESTac device protocol v1
// (docs/device-protocol.md). All protocol and timing logic lives in the portable C core
// (../src, ../include, host-tested by `make test`); this sketch only moves bytes and applies
// edges to pins.
//
// Build: the core must sit in the sketch folder. Link (or copy, e.g. for the Arduino IDE) it:
//   cd devices/firmware/fingertac && ln -sf ../src/*.c ../include/*.h .
//   arduino-cli compile --fqbn esp32:esp32:esp32 .
//   arduino-cli upload  --fqbn esp32:esp32:esp32 -p /dev/ttyUSB0 .
// `make sketch-check` compile-checks this file on the host against test/arduino_stub.
#include <Arduino.h>
#include <esp_timer.h>

#include "viestac_arduino.h"

static const unsigned long BAUD = 115200;        // §0: 115200 8N1
static const uint8_t LRA_PIN[2] = { 25, 26 };    // PWM input of the LRA driver of channel 0, 1
static const uint8_t PWM_BITS = 10;
static const uint32_t PWM_FULL = (1u << PWM_BITS) - 1;
static const uint32_t NO_CARRIER_PWM_HZ = 20000; // texture: no carrier, a fast PWM is a DC level
static const size_t EDGE_BATCH = 8;

static vt_device dev;                            // the whole device state, no heap
static uint32_t pwm_hz[2];

static void apply(const vt_edge &e)
{
    if (e.channel >= 2)
        return;
    uint8_t pin = LRA_PIN[e.channel];
    uint32_t hz = e.carrier_hz ? e.carrier_hz : NO_CARRIER_PWM_HZ;
    if (hz != pwm_hz[e.channel]) {
        ledcChangeFrequency(pin, hz, PWM_BITS);
        pwm_hz[e.channel] = hz;
    }
    // A square wave at the carrier drives the LRA hardest at 50 % duty, so intensity scales
    // that; without a carrier (texture) the gate itself is the vibration and intensity is the level.
    uint32_t span = e.carrier_hz ? PWM_FULL / 2 : PWM_FULL;
    ledcWrite(pin, e.gate ? span * e.intensity / 100 : 0);
}

void setup()
{
    Serial.begin(BAUD);
    vt_device_init(&dev, &vt_model_fingertac);
    for (int i = 0; i < 2; i++) {
        pwm_hz[i] = vt_model_fingertac.carrier_hz;
        ledcAttach(LRA_PIN[i], pwm_hz[i], PWM_BITS);
        ledcWrite(LRA_PIN[i], 0);
    }
}

void loop()
{
    // 64-bit µs since boot: no 71-minute wrap as with 32-bit micros().
    uint64_t now = (uint64_t)esp_timer_get_time();
    vt_serial_pump(&dev, now);

    // Edges carry their exact scheduled time; polling from loop() applies them within a few µs
    // (a timer alarm at vt_device_next_edge_us() would make that exact).
    vt_edge edges[EDGE_BATCH];
    size_t k;
    do {
        k = vt_device_advance(&dev, now, edges, EDGE_BATCH);
        for (size_t i = 0; i < k; i++)
            apply(edges[i]);
    } while (k == EDGE_BATCH);
}
