// The part of Arduino's Wire (I2C) library spherestep_drive.ino uses (firmware/test/test_drive_sketch.cpp defines
// it): Teensy 4.1's Wire and Wire1 buses.
#ifndef SPHERESTEP_TEST_WIRE_H
#define SPHERESTEP_TEST_WIRE_H

#include <stddef.h>
#include <stdint.h>

class TwoWire {
 public:
  void begin();
  void setClock(uint32_t hz);
  void beginTransmission(uint8_t address);
  size_t write(uint8_t data);
  uint8_t endTransmission(bool sendStop = true);
  uint8_t requestFrom(uint8_t address, uint8_t quantity);
  int read();
};

extern TwoWire Wire;
extern TwoWire Wire1;

#endif  // SPHERESTEP_TEST_WIRE_H
