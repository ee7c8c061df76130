// Arduino glue shared by the ESP32 sketches: moves bytes between Serial and the firmware core.
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

#endif
