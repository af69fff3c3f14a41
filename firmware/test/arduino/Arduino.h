// The few Arduino core functions the sketches use, for compiling and running them on the host
// (firmware/test/test_sketch.cpp defines them for the relay sketch spherestep.ino, test_drive_sketch.cpp for
// the Teensy 4.1's spherestep_drive.ino: pins, PWM, the clock and the serial port become recordable state).
// Declarations only: a cross-compile checks a sketch against them without linking.
#ifndef SPHERESTEP_TEST_ARDUINO_H
#define SPHERESTEP_TEST_ARDUINO_H

#include <math.h>
#include <stddef.h>
#include <stdint.h>

#define HIGH 1
#define LOW 0
#define OUTPUT 1

void pinMode(uint8_t pin, uint8_t mode);
void digitalWrite(uint8_t pin, uint8_t value);
void delay(unsigned long ms);
unsigned long millis();

// Teensyduino (Teensy 4.x core): fast pin writes, PWM resolution and frequency, the µs clock
void digitalWriteFast(uint8_t pin, uint8_t value);
void analogWrite(uint8_t pin, int value);
void analogWriteResolution(unsigned bits);
void analogWriteFrequency(uint8_t pin, float hz);
uint32_t micros();

class HardwareSerial {
 public:
  void begin(unsigned long baud);
  int available();
  int read();
  size_t write(const uint8_t* data, size_t length);
};

extern HardwareSerial Serial;

#endif  // SPHERESTEP_TEST_ARDUINO_H
