// spherestep current-mode coil controller for a Teensy 4.1 (docs/hardware.md): 29 DRV8874 H-bridges in PH/EN
// mode, IPROPI current sense through four MCP3208 ADCs, eight TMAG5273A2 magnetometers on two I2C buses, a
// supply relay as the all-off backstop. Protocol version 2 (and version 1 for relay plans), the PI current loops
// and every limit live in drive.cpp (plain C++, tested on the host with g++ against firmware/test/vectors2.txt);
// this file only moves numbers between that core and the pins. Build: copy ../spherestep/{drive,protocol}.{h,cpp}
// and wire.h next to this sketch (or add ../spherestep to the include path) and build for Teensy 4.1.
#include <Arduino.h>
#include <SPI.h>
#include <Wire.h>

#include "drive.h"
#include "spherestep_config.h"

namespace {

const uint8_t COILS = 29;
const uint8_t SENSORS = 8;
const uint16_t WATCHDOG_MS = 100;
const uint32_t PERIOD_US = 1000;  // the current loop at 1 kHz (the PWM itself at 20 kHz)
const char NAME[] = "spherestep-t41";
// HELLO,2 reports the supply, the coils' resistance and inductance and the current limit, and the host refuses to
// drive a design whose DriveLimits differ by more than 2 % (docs/protocol.md): the coils' constants come from the
// design, in spherestep_config.h (`spherestep export DESIGN --out DIR` writes it; the one here is the built-in
// prototype's iron-cored coil). Copy the header of your design next to this sketch.
static_assert(spherestep_config::COILS == COILS, "spherestep_config.h is for a design with another coil count");
const spherestep::Limits LIMITS = spherestep_config::LIMITS;
// loop: the design's supply and inductance, 2 pi 40 Hz closed-loop bandwidth, relay-mode current (mA) at the
// design's nominal current, 8118 nT per count (TMAG5273A2, +-266 mT)
const spherestep::Loop LOOP = {spherestep_config::SUPPLY_V, spherestep_config::INDUCTANCE_H, 2 * 3.14159265358979 * 40,
                               PERIOD_US, spherestep_config::NOMINAL_MA, 8118};

// PWM-capable (Teensyduino's teensy4/pwm.c); 11-13 are SPI, 16-19 are I2C. Pin 41 (once coil 22's) has no PWM on
// the 4.1, so analogWrite left that coil undriven: coil 22 is on pin 51, a bottom pad (no QSPI memory chip fitted).
const uint8_t EN_PINS[COILS] = {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 14, 15, 22, 23, 24, 25, 28, 29, 33, 36, 37,
                                51, 42, 43, 44, 45, 46, 47};
const uint8_t PIN_NSLEEP = 30;      // every DRV8874 nSLEEP: low = all asleep
const uint8_t PIN_SUPPLY = 31;      // gate of the supply relay's MOSFET: high = bridge supply on
const uint8_t PIN_LATCH = 32;       // 74HC595 RCLK (PH of the 29 bridges, 4 chained registers on SPI)
const uint8_t PIN_ADC_CS[4] = {34, 35, 38, 39};  // MCP3208 chip selects
const double AMPS_PER_COUNT = 3.0 / 4095 / 1.12;  // 3.0 V reference, 1.12 V/A (450 uA/A into 2.49 kohm)
const uint8_t MAG_ADDRESS[4] = {0x35, 0x22, 0x78, 0x44};  // TMAG5273 A2, B2, C2, D2

class Board : public spherestep::Bridges {
 public:
  void measure(int32_t* ma) override {
    for (uint8_t k = 0; k < COILS; ++k) {
      // IPROPI only gives the magnitude: the sign is the direction the bridge drives
      const double amps = readAdc(k / 8, k % 8) * AMPS_PER_COUNT;
      ma[k] = (int32_t)lround(1000.0 * (reversed_ & (1ul << k) ? -amps : amps));
    }
  }
  void drive(const double* duty, bool enabled) override {
    if (!enabled) {
      digitalWriteFast(PIN_NSLEEP, LOW);  // all bridges asleep first (microseconds), then the supply
      digitalWriteFast(PIN_SUPPLY, LOW);
      for (uint8_t k = 0; k < COILS; ++k) analogWrite(EN_PINS[k], 0);
      return;
    }
    uint32_t reversed = 0;
    for (uint8_t k = 0; k < COILS; ++k) {
      if (duty[k] < 0) reversed |= 1ul << k;
      analogWrite(EN_PINS[k], (int)lround(fabs(duty[k]) * 4095));
    }
    if (reversed != reversed_) writeDirections(reversed);
    digitalWriteFast(PIN_SUPPLY, HIGH);
    digitalWriteFast(PIN_NSLEEP, HIGH);
  }
  uint32_t sense(int32_t* counts) override {
    uint32_t stale = 0;
    for (uint8_t s = 0; s < SENSORS; ++s) {
      TwoWire& bus = s < 4 ? Wire : Wire1;
      bus.beginTransmission(MAG_ADDRESS[s % 4]);
      bus.write(0x12);  // X_MSB_RESULT: then X, Y, Z, 16 bits each
      if (bus.endTransmission(false) != 0 || bus.requestFrom(MAG_ADDRESS[s % 4], (uint8_t)6) != 6) {
        stale |= 1ul << s;  // no answer: keep the last sample, flag it
        for (uint8_t a = 0; a < 3; ++a) counts[3 * s + a] = last_[3 * s + a];
        continue;
      }
      for (uint8_t a = 0; a < 3; ++a) {
        const int16_t v = (int16_t)((bus.read() << 8) | bus.read());
        counts[3 * s + a] = last_[3 * s + a] = v;
      }
    }
    return stale;
  }

 private:
  uint16_t readAdc(uint8_t chip, uint8_t channel) {
    SPI.beginTransaction(SPISettings(2000000, MSBFIRST, SPI_MODE0));
    digitalWriteFast(PIN_ADC_CS[chip], LOW);
    SPI.transfer(0x06 | (channel >> 2));  // start, single-ended, channel bit 2
    const uint8_t high = SPI.transfer((uint8_t)(channel << 6));
    const uint8_t low = SPI.transfer(0);
    digitalWriteFast(PIN_ADC_CS[chip], HIGH);
    SPI.endTransaction();
    return (uint16_t)(((high & 0x0F) << 8) | low);
  }
  void writeDirections(uint32_t reversed) {
    SPI.beginTransaction(SPISettings(8000000, MSBFIRST, SPI_MODE0));
    for (int shift = 24; shift >= 0; shift -= 8) SPI.transfer((uint8_t)(reversed >> shift));
    digitalWriteFast(PIN_LATCH, HIGH);
    digitalWriteFast(PIN_LATCH, LOW);
    SPI.endTransaction();
    reversed_ = reversed;
  }
  uint32_t reversed_ = 0;
  int32_t last_[3 * SENSORS] = {0};
};

Board board;
spherestep::CurrentDevice* device = nullptr;
char reply[spherestep::MAX_REPLY2];
uint32_t nextStep = 0;

}  // namespace

void setup() {
  pinMode(PIN_NSLEEP, OUTPUT);
  digitalWriteFast(PIN_NSLEEP, LOW);
  pinMode(PIN_SUPPLY, OUTPUT);
  digitalWriteFast(PIN_SUPPLY, LOW);
  pinMode(PIN_LATCH, OUTPUT);
  for (uint8_t c = 0; c < 4; ++c) {
    pinMode(PIN_ADC_CS[c], OUTPUT);
    digitalWriteFast(PIN_ADC_CS[c], HIGH);
  }
  analogWriteResolution(12);
  for (uint8_t k = 0; k < COILS; ++k) {
    analogWriteFrequency(EN_PINS[k], 20000);
    analogWrite(EN_PINS[k], 0);
  }
  SPI.begin();
  Wire.begin();
  Wire.setClock(1000000);
  Wire1.begin();
  Wire1.setClock(1000000);
  static spherestep::CurrentDevice instance(board, COILS, SENSORS, WATCHDOG_MS, LIMITS, LOOP, NAME);
  device = &instance;
  Serial.begin(115200);  // native USB: the baud rate is ignored
  nextStep = micros();
}

void loop() {
  while (Serial.available() > 0) {
    const size_t n = device->receive((char)Serial.read(), micros(), reply);
    if (n > 0) Serial.write(reinterpret_cast<const uint8_t*>(reply), n);
  }
  const uint32_t now = micros();
  if ((int32_t)(now - nextStep) >= 0) {
    device->step(now);
    nextStep += PERIOD_US;
  }
}
