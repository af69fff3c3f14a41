// The few Arduino core functions spherestep.ino uses, for compiling and running the sketch on the host
// (firmware/test/test_sketch.cpp defines them: pins and the serial port become recordable state).
#ifndef SPHERESTEP_TEST_ARDUINO_H
#define SPHERESTEP_TEST_ARDUINO_H

#include <stddef.h>
#include <stdint.h>

#define HIGH 1
#define LOW 0
#define OUTPUT 1

void pinMode(uint8_t pin, uint8_t mode);
void digitalWrite(uint8_t pin, uint8_t value);
void delay(unsigned long ms);
unsigned long millis();

class HardwareSerial {
 public:
  void begin(unsigned long baud);
  int available();
  int read();
  size_t write(const uint8_t* data, size_t length);
};

extern HardwareSerial Serial;

#endif  // SPHERESTEP_TEST_ARDUINO_H
