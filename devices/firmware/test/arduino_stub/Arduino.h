// A minimal fake of the Arduino-ESP32 (core 3.x) API used by the sketches, so that
// `make sketch-check` can compile-check them on the host (g++ -x c++ -fsyntax-only).
// Declarations only matter; the bodies do nothing.
#pragma once
#include <math.h>
#include <stddef.h>
#include <stdint.h>

#include "esp_timer.h"

#define HIGH 0x1
#define LOW 0x0
#define INPUT 0x01
#define OUTPUT 0x03

typedef uint8_t byte;

class HardwareSerial {
public:
    void begin(unsigned long baud) { (void)baud; }
    int available() { return 0; }
    int read() { return -1; }
    int availableForWrite() { return 128; }
    size_t write(uint8_t b) { (void)b; return 1; }
    size_t write(const uint8_t *buf, size_t n) { (void)buf; return n; }
    void flush() {}
};
static HardwareSerial Serial;

inline void pinMode(uint8_t pin, uint8_t mode) { (void)pin; (void)mode; }
inline void digitalWrite(uint8_t pin, uint8_t val) { (void)pin; (void)val; }
inline unsigned long micros() { return 0; }
inline unsigned long millis() { return 0; }
inline void delay(uint32_t ms) { (void)ms; }

// LEDC PWM, Arduino-ESP32 3.x pin-based API.
inline bool ledcAttach(uint8_t pin, uint32_t freq, uint8_t resolution) { (void)pin; (void)freq; (void)resolution; return true; }
inline bool ledcWrite(uint8_t pin, uint32_t duty) { (void)pin; (void)duty; return true; }
inline uint32_t ledcChangeFrequency(uint8_t pin, uint32_t freq, uint8_t resolution) { (void)pin; (void)resolution; return freq; }
