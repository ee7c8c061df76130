// ViESTac devkit firmware (ESP32, Arduino-ESP32 core 3.x): the reference for new devices. One
// fingertip with an LRA (LEDC PWM at its 235 Hz resonance), a Peltier element behind an H-bridge
// and a friction display, controlled over serial with the ViESTac device protocol v1
// (docs/device-protocol.md). All protocol and timing logic lives in the portable C core
// (../src, ../include, host-tested by `make test`); this sketch only moves bytes and applies
// each edge's pattern, temperature and friction layers to pins.
//
// Build: the core must sit in the sketch folder. Link (or copy, e.g. for the Arduino IDE) it:
//   cd devices/firmware/devkit && ln -sf ../src/*.c ../include/*.h .
//   arduino-cli compile --fqbn esp32:esp32:esp32 .
//   arduino-cli upload  --fqbn esp32:esp32:esp32 -p /dev/ttyUSB0 .
// `make sketch-check` compile-checks this file on the host against test/arduino_stub.
#include <Arduino.h>
#include <esp_timer.h>
#include <math.h>

#include "viestac_arduino.h"

static const unsigned long BAUD = 115200;       // §0: 115200 8N1
static const uint8_t LRA_PIN = 25;              // PWM input of the LRA driver
static const uint8_t PELTIER_PWM_PIN = 26;      // Peltier H-bridge: enable (PWM) ...
static const uint8_t PELTIER_DIR_PIN = 27;      // ... and direction (HIGH = heat the skin side)
static const uint8_t FRICTION_PIN = 14;         // amplitude input of the friction display's driver
static const uint32_t DRIVE_PWM_HZ = 20000;     // above hearing; both drivers filter it to a level
static const uint8_t PWM_BITS = 10;
static const float PWM_FULL = (float)((1u << PWM_BITS) - 1);
static const float NEUTRAL_C = 32.0f;           // skin temperature: the Peltier is idle
static const float FULL_DRIVE_C = 15.0f;        // |setpoint - neutral| that gets the full H-bridge
static const float FRICTION_MAX = 5.0f;         // SET_FRICTION's largest coefficient (§2)

static vt_device dev;                           // the whole device state, no heap
static vt_lra lra;

static uint32_t duty(float level)               // 0..1 -> LEDC duty
{
    return (uint32_t)(fminf(fmaxf(level, 0.0f), 1.0f) * PWM_FULL + 0.5f);
}

// Open loop: the drive grows with the distance of the setpoint from skin temperature, its sign
// picks heating or cooling. What the skin side reaches depends on the heat sink, the finger and
// time, so a real build closes the loop on a thermistor at the skin side (e.g. PI control of this
// duty, with a limit on the cold side's rate) instead.
static void drive_peltier(const vt_edge &e)
{
    float delta = e.temperature_on ? e.centi_celsius / 100.0f - NEUTRAL_C : 0.0f;
    digitalWrite(PELTIER_DIR_PIN, delta >= 0.0f ? HIGH : LOW);
    ledcWrite(PELTIER_PWM_PIN, duty(fabsf(delta) / FULL_DRIVE_C));
}

// The display's driver takes an amplitude (0 = idle surface). Linear in the coefficient here;
// which amplitude feels like which coefficient is the display's own calibration.
static void drive_friction(const vt_edge &e)
{
    ledcWrite(FRICTION_PIN, duty(e.friction_on ? e.friction_milli / 1000.0f / FRICTION_MAX : 0.0f));
}

// Every edge is the channel's whole output; pattern toggles leave temperature and friction as
// they are, so rewriting those drives is harmless.
static void apply_edge(const vt_edge *e)
{
    vt_lra_apply(&lra, e);
    drive_peltier(*e);
    drive_friction(*e);
}

void setup()
{
    Serial.begin(BAUD);
    vt_device_init(&dev, &vt_model_devkit);
    vt_lra_attach(&lra, LRA_PIN, vt_model_devkit.carrier_hz);
    pinMode(PELTIER_DIR_PIN, OUTPUT);
    ledcAttach(PELTIER_PWM_PIN, DRIVE_PWM_HZ, PWM_BITS);
    ledcAttach(FRICTION_PIN, DRIVE_PWM_HZ, PWM_BITS);
    drive_peltier(vt_device_channel(&dev, 0)->last);
    drive_friction(vt_device_channel(&dev, 0)->last);
}

void loop()
{
    // 64-bit µs since boot: no 71-minute wrap as with 32-bit micros().
    uint64_t now = (uint64_t)esp_timer_get_time();
    vt_serial_pump(&dev, now);

    vt_drain_edges(&dev, now, apply_edge);
}
