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

static vt_device dev;                            // the whole device state, no heap
static vt_lra lra[2];

static void apply_edge(const vt_edge *e)
{
    if (e->channel < 2)
        vt_lra_apply(&lra[e->channel], e);
}

void setup()
{
    Serial.begin(BAUD);
    vt_device_init(&dev, &vt_model_fingertac);
    for (int i = 0; i < 2; i++)
        vt_lra_attach(&lra[i], LRA_PIN[i], vt_model_fingertac.carrier_hz);
}

void loop()
{
    // 64-bit µs since boot: no 71-minute wrap as with 32-bit micros().
    uint64_t now = (uint64_t)esp_timer_get_time();
    vt_serial_pump(&dev, now);

    // Edges carry their exact scheduled time; polling from loop() applies them within a few µs
    // (a timer alarm at vt_device_next_edge_us() would make that exact).
    vt_drain_edges(&dev, now, apply_edge);
}
