// Runs the Teensy 4.1 sketch itself (spherestep_drive/spherestep_drive.ino) on the host against a recording board
// behind the Arduino stand-ins in arduino/: pins and their PWM, the 74HC595 chain holding the bridges' PH lines,
// the four MCP3208 ADCs reading the bridges' IPROPI (a magnitude), the TMAG5273 magnetometers on Wire and Wire1,
// the clock and the USB serial port. Checks the pin map, the sign of the current reads, the magnetometers' stale
// flags and the supply relay opening on a trip. g++ -std=c++11 -Iarduino -I../spherestep -I../spherestep_drive
// test_drive_sketch.cpp ../spherestep/drive.cpp ../spherestep/protocol.cpp; prints "N passed, N failed".
#include "check.h"
#include <cstdio>
#include <map>
#include <string>
#include <vector>

#include "Arduino.h"
#include "SPI.h"
#include "Wire.h"
#include "spherestep_drive.ino"

namespace {


// The Teensy 4.1's PWM pins (Teensyduino's teensy4/pwm.c, pwm_pin_info for ARDUINO_TEENSY41: FlexPWM or QuadTimer)
bool pwmPin(int pin) {
  static const int pins[] = {0,  1,  2,  3,  4,  5,  6,  7,  8,  9,  10, 11, 12, 13, 14, 15, 18, 19,
                             22, 23, 24, 25, 28, 29, 33, 36, 37, 42, 43, 44, 45, 46, 47, 51, 54};
  for (int p : pins) {
    if (p == pin) return true;
  }
  return false;
}

// -- the recording board ----------------------------------------------------------------------------------------
uint8_t level[64];
bool output[64];
std::map<int, int> pwm;        // pin -> last analogWrite value
std::map<int, float> pwmHz;    // pin -> analogWriteFrequency
unsigned pwmBits = 8;
std::vector<std::string> events;  // pin writes and PWM writes, in order
uint32_t clockUs = 0;
std::string rx, tx;
int adc[32];           // MCP3208 counts per coil (chip k / 8, channel k % 8): IPROPI, a magnitude
uint32_t shifter = 0;  // the 74HC595 chain: bytes shifted in while no ADC is selected
uint32_t phase = 0;    // latched on RCLK's rising edge: bit k = bridge k reversed
int adcByte = 0;       // bytes of the transaction with the selected ADC
int adcChannel = 0;

int selectedAdc() {
  for (int c = 0; c < 4; ++c) {
    if (output[PIN_ADC_CS[c]] && level[PIN_ADC_CS[c]] == LOW) return c;
  }
  return -1;
}

struct Magnetometer {
  bool present;
  int16_t counts[3];
};
Magnetometer sensors[2][4];  // [bus][address index]
int bus = -1, target = -1;
std::vector<uint8_t> wireRx;

int addressIndex(uint8_t address) {
  for (int i = 0; i < 4; ++i) {
    if (MAG_ADDRESS[i] == address) return i;
  }
  return -1;
}

std::string frame(const std::string& body) {
  char crc[8];
  std::snprintf(crc, sizeof crc, "%04X", spherestep::crc16(body.data(), body.size()));
  return "$" + body + "*" + crc + "\n";
}

// The sketch's answer to one frame after one pass of loop() at clockUs.
std::string exchange(const std::string& body) {
  rx = frame(body);
  tx.clear();
  loop();
  return tx;
}

// One pass of loop() 1 ms later: one control step.
void stepOnce() {
  clockUs += 1000;
  loop();
}

}  // namespace

void pinMode(uint8_t pin, uint8_t mode) { output[pin] = mode == OUTPUT; }
void digitalWrite(uint8_t pin, uint8_t value) { digitalWriteFast(pin, value); }
void digitalWriteFast(uint8_t pin, uint8_t value) {
  if (pin == PIN_LATCH && value == HIGH && level[pin] == LOW) phase = shifter;
  if (value == LOW && level[pin] == HIGH) {
    for (int c = 0; c < 4; ++c) {
      if (pin == PIN_ADC_CS[c]) adcByte = 0;
    }
  }
  level[pin] = value;
  events.push_back("pin " + std::to_string(pin) + (value == HIGH ? " high" : " low"));
}
void delay(unsigned long) {}
unsigned long millis() { return clockUs / 1000; }
uint32_t micros() { return clockUs; }
void analogWrite(uint8_t pin, int value) {
  pwm[pin] = value;
  events.push_back("pwm " + std::to_string(pin) + " " + std::to_string(value));
}
void analogWriteResolution(unsigned bits) { pwmBits = bits; }
void analogWriteFrequency(uint8_t pin, float hz) { pwmHz[pin] = hz; }

void HardwareSerial::begin(unsigned long) {}
int HardwareSerial::available() { return (int)rx.size(); }
int HardwareSerial::read() {
  if (rx.empty()) return -1;
  const int c = (unsigned char)rx[0];
  rx.erase(0, 1);
  return c;
}
size_t HardwareSerial::write(const uint8_t* data, size_t length) {
  tx.append(reinterpret_cast<const char*>(data), length);
  return length;
}
HardwareSerial Serial;

void SPIClass::begin() {}
void SPIClass::beginTransaction(const SPISettings&) {}
void SPIClass::endTransaction() {}
uint8_t SPIClass::transfer(uint8_t data) {
  const int chip = selectedAdc();
  if (chip < 0) {  // the shift registers
    shifter = (shifter << 8) | data;
    return 0;
  }
  // MCP3208: start bit, single-ended, D2 in the first byte; D1 D0 at the top of the second; then 12 bits
  const int n = adcByte++;
  if (n == 0) {
    adcChannel = (data & 1) << 2;
    return 0;
  }
  if (n == 1) {
    adcChannel |= data >> 6;
    return (uint8_t)((adc[8 * chip + adcChannel] >> 8) & 0x0F);
  }
  return (uint8_t)(adc[8 * chip + adcChannel] & 0xFF);
}
SPIClass SPI;

void TwoWire::begin() {}
void TwoWire::setClock(uint32_t) {}
void TwoWire::beginTransmission(uint8_t address) {
  bus = this == &Wire ? 0 : 1;
  target = addressIndex(address);
}
size_t TwoWire::write(uint8_t) { return 1; }
uint8_t TwoWire::endTransmission(bool) { return target >= 0 && sensors[bus][target].present ? 0 : 2; }
uint8_t TwoWire::requestFrom(uint8_t address, uint8_t quantity) {
  const int i = addressIndex(address);
  const int b = this == &Wire ? 0 : 1;
  wireRx.clear();
  if (i < 0 || !sensors[b][i].present || quantity != 6) return 0;
  for (int a = 0; a < 3; ++a) {
    wireRx.push_back((uint8_t)((uint16_t)sensors[b][i].counts[a] >> 8));
    wireRx.push_back((uint8_t)(sensors[b][i].counts[a] & 0xFF));
  }
  return 6;
}
int TwoWire::read() {
  if (wireRx.empty()) return -1;
  const int v = wireRx.front();
  wireRx.erase(wireRx.begin());
  return v;
}
TwoWire Wire;
TwoWire Wire1;

int main() {
  for (int b = 0; b < 2; ++b) {
    for (int i = 0; i < 4; ++i) sensors[b][i] = Magnetometer{true, {0, 0, 0}};
  }
  setup();

  // pin map: 29 distinct PWM pins at 20 kHz, 12 bits, off; no clash with SPI (11-13), I2C (16-19) or control pins
  bool pinsOk = true;
  for (uint8_t k = 0; k < COILS; ++k) {
    const int p = EN_PINS[k];
    for (uint8_t j = 0; j < k; ++j) pinsOk = pinsOk && EN_PINS[j] != p;
    const bool control = p == PIN_NSLEEP || p == PIN_SUPPLY || p == PIN_LATCH || p == PIN_ADC_CS[0] ||
                         p == PIN_ADC_CS[1] || p == PIN_ADC_CS[2] || p == PIN_ADC_CS[3];
    const bool ok = pwmPin(p) && !(p >= 11 && p <= 13) && !(p >= 16 && p <= 19) && !control;
    check(ok, "coil " + std::to_string(k) + "'s EN pin " + std::to_string(p) + " is a free PWM pin of the Teensy 4.1");
    pinsOk = pinsOk && ok && pwmHz[p] == 20000.0f && pwm.count(p) && pwm[p] == 0;
  }
  check(pinsOk && pwmBits == 12, "29 distinct EN pins, 20 kHz, 12-bit, all at 0 after setup");
  check(output[PIN_NSLEEP] && level[PIN_NSLEEP] == LOW && output[PIN_SUPPLY] && level[PIN_SUPPLY] == LOW,
        "bridges asleep and the supply relay open after setup");
  bool csHigh = true;
  for (int c = 0; c < 4; ++c) csHigh = csHigh && output[PIN_ADC_CS[c]] && level[PIN_ADC_CS[c]] == HIGH;
  check(csHigh, "every ADC deselected after setup");

  std::string r = exchange("00,HELLO,2");
  check(r == frame("00,ACK,HELLO,2,29,8,100,1000,289,100,8118,24000,82958,650226,1,spherestep-t41"), "HELLO: " + r);

  // the prototype's coils (spherestep_config.h: 289 mA, 82.96 ohm, 650 mH); coil 0 +200 mA, coil 1 -200 mA: the first step drives coil 1 reversed (PH bit 1), both EN up, supply on
  std::string block = "00C8FF38";
  for (int k = 2; k < COILS; ++k) block += "0000";
  r = exchange("01,DRIVE," + block);
  check(r.compare(0, 17, "$01,ACK,DRIVE,000") == 0, "DRIVE acknowledged: " + r);
  events.clear();
  stepOnce();
  check(phase == 0x2u, "the 74HC595 chain latched bridge 1 reversed, bridge 0 forward (got " +
                           std::to_string(phase) + ")");
  check(pwm[EN_PINS[0]] > 0 && pwm[EN_PINS[1]] > 0 && pwm[EN_PINS[2]] == 0,
        "EN 0 and 1 driven, EN 2 not (" + std::to_string(pwm[EN_PINS[0]]) + ", " + std::to_string(pwm[EN_PINS[1]]) +
            ")");
  check(pwm[EN_PINS[0]] == (int)lround(fabs(device->duty(0)) * 4095) &&
            pwm[EN_PINS[1]] == (int)lround(fabs(device->duty(1)) * 4095) && device->duty(1) < 0,
        "EN values are |duty| x 4095, the sign is the PH line");
  check(level[PIN_SUPPLY] == HIGH && level[PIN_NSLEEP] == HIGH, "supply relay closed, bridges awake");

  // sign of the reads: IPROPI is a magnitude; 153 counts = 100 mA (3.0 V / 4095 / 1.12 V/A); coil 1 reversed,
  // coil 9 (ADC 1, channel 1) forward
  adc[0] = 153;
  adc[1] = 153;
  adc[9] = 153;
  sensors[0][0].counts[0] = 1;
  sensors[0][0].counts[1] = -2;
  sensors[0][0].counts[2] = 3;
  sensors[1][1].present = false;  // sensor 5: Wire1, address 0x22
  r = exchange("02,READ");
  std::string currents = "0064FF9C";
  for (int k = 2; k < COILS; ++k) currents += k == 9 ? "0064" : "0000";
  check(r.find("," + currents + ",") != std::string::npos, "currents 100, -100 (reversed), ..., 100 on coil 9: " + r);
  check(r.find(",20," + currents + ",0001FFFE0003") != std::string::npos,
        "sensor 5 stale (mask 20), sensor 0 reads 1, -2, 3: " + r);

  // a trip opens the supply relay: 4095 counts on coil 2 = 2.68 A > 1.25 x 0.289 A: bridges asleep first, then the
  // supply, then every EN at 0
  adc[2] = 4095;
  events.clear();
  stepOnce();
  check(device->tripped() != nullptr && std::string(device->tripped()) == "OVER" && device->tripCoil() == 2,
        "over-current on coil 2 trips OVER");
  size_t sleepAt = events.size(), supplyAt = events.size();
  for (size_t i = 0; i < events.size(); ++i) {
    if (events[i] == "pin " + std::to_string(PIN_NSLEEP) + " low" && sleepAt == events.size()) sleepAt = i;
    if (events[i] == "pin " + std::to_string(PIN_SUPPLY) + " low" && supplyAt == events.size()) supplyAt = i;
  }
  check(sleepAt < supplyAt && supplyAt < events.size(), "nSLEEP low before the supply relay opens");
  bool allZero = level[PIN_SUPPLY] == LOW && level[PIN_NSLEEP] == LOW;
  for (uint8_t k = 0; k < COILS; ++k) allZero = allZero && pwm[EN_PINS[k]] == 0;
  check(allZero, "after the trip every EN is 0, the bridges asleep, the supply cut");
  r = exchange("03,READ");
  check(r == frame("03,NAK,OVER"), "the trip is answered: " + r);

  return report();
}
