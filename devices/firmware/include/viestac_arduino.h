// Arduino glue shared by the ESP32 sketches: moves bytes between Serial and the firmware core,
// hands the core's due edges to the sketch, and drives an LRA from a channel's pattern layer.
// Header-only and Arduino-only (the portable core in ../src never includes it).
#ifndef VIESTAC_ARDUINO_H
#define VIESTAC_ARDUINO_H

#include <Arduino.h>

#include "viestac_fw.h"

// Feed what Serial has received to the core at `now_us`, then write only what the UART buffer
// takes now, so a slow link never stalls the caller's actuator updates.
static inline void vt_serial_pump(vt_device *dev, uint64_t now_us)
{
    uint8_t buf[64];
    size_t n = 0;
    while (n < sizeof buf && Serial.available() > 0)
        buf[n++] = (uint8_t)Serial.read();
    if (n)
        vt_device_receive(dev, buf, n, now_us);

    int room = Serial.availableForWrite();
    if (room > 0 && vt_device_output_pending(dev)) {
        n = vt_device_take_output(dev, buf, (size_t)room < sizeof buf ? (size_t)room : sizeof buf);
        Serial.write(buf, n);
    }
}

// Hand every edge due by `now_us` to `apply`, in time order, in batches of a few (a burst of
// scheduled toggles after a long loop() never needs more than a small stack buffer).
static inline void vt_drain_edges(vt_device *dev, uint64_t now_us, void (*apply)(const vt_edge *e))
{
    vt_edge edges[8];
    size_t k;
    do {
        k = vt_device_advance(dev, now_us, edges, sizeof edges / sizeof edges[0]);
        for (size_t i = 0; i < k; i++)
            apply(&edges[i]);
    } while (k == sizeof edges / sizeof edges[0]);
}

// One LRA behind a driver with a PWM input (LEDC): a square wave at the edge's carrier, or, when
// there is none (texture), a fast PWM that the driver sees as a DC level.
struct vt_lra {
    uint8_t pin;
    uint32_t pwm_hz;                        // the LEDC frequency now set, changed only when needed
};

static const uint8_t VT_LRA_PWM_BITS = 10;
static const uint32_t VT_LRA_PWM_FULL = (1u << VT_LRA_PWM_BITS) - 1;
static const uint32_t VT_LRA_NO_CARRIER_HZ = 20000;

static inline void vt_lra_attach(vt_lra *lra, uint8_t pin, uint32_t carrier_hz)
{
    lra->pin = pin;
    lra->pwm_hz = carrier_hz;
    ledcAttach(pin, carrier_hz, VT_LRA_PWM_BITS);
    ledcWrite(pin, 0);
}

// Show the pattern layer of an edge.
static inline void vt_lra_apply(vt_lra *lra, const vt_edge *e)
{
    uint32_t hz = e->carrier_hz ? e->carrier_hz : VT_LRA_NO_CARRIER_HZ;
    if (hz != lra->pwm_hz) {
        ledcChangeFrequency(lra->pin, hz, VT_LRA_PWM_BITS);
        lra->pwm_hz = hz;
    }
    // A square wave at the carrier drives the LRA hardest at 50 % duty, so intensity scales
    // that; without a carrier (texture) the gate itself is the vibration and intensity is the level.
    uint32_t span = e->carrier_hz ? VT_LRA_PWM_FULL / 2 : VT_LRA_PWM_FULL;
    ledcWrite(lra->pin, e->gate ? span * e->intensity / 100 : 0);
}

#endif
