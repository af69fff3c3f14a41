// The part of Arduino's SPI library spherestep_drive.ino uses (firmware/test/test_drive_sketch.cpp defines it).
#ifndef SPHERESTEP_TEST_SPI_H
#define SPHERESTEP_TEST_SPI_H

#include <stdint.h>

#define MSBFIRST 1
#define SPI_MODE0 0

class SPISettings {
 public:
  SPISettings(uint32_t clock, uint8_t bitOrder, uint8_t dataMode) : clock(clock), bitOrder(bitOrder), mode(dataMode) {}
  uint32_t clock;
  uint8_t bitOrder;
  uint8_t mode;
};

class SPIClass {
 public:
  void begin();
  void beginTransaction(const SPISettings& settings);
  uint8_t transfer(uint8_t data);
  void endTransaction();
};

extern SPIClass SPI;

#endif  // SPHERESTEP_TEST_SPI_H
