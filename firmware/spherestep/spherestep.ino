// spherestep reference firmware: a serial coil controller for relay boards or H-bridges.
//
// The host (`spherestep run PLAN --port /dev/ttyACM0 --rate 10`) streams commutation steps as relay masks
// over the line protocol of docs/protocol.md; protocol.h/.cpp parse it and keep the safety state machine
// (watchdog, break-before-make), this file only maps channels to pins.
//
// Target: Arduino Mega 2560 (pins 22..53 give the 32 channels of four 8-relay boards, Sec. IV-B of
// Chirikjian & Stein 1999). Channel k of the default plan channel map is the enable relay of coil k for
// k < N and the polarity relay of coil k - N for k >= N (N coils, 2N channels). With H-bridges, wire an
// enable channel to the bridge's enable input and the polarity channel to its direction input.
#include <Arduino.h>

#include "protocol.h"

#if defined(__AVR__)
#include <avr/wdt.h>
#endif

namespace {

// Up to 64 channels: append pins 2..21 and A0..A15 (54..69) and raise CHANNELS (58 for a 29-coil stator).
const uint8_t CHANNELS = 32;
const uint8_t CHANNEL_PINS[CHANNELS] = {22, 23, 24, 25, 26, 27, 28, 29, 30, 31, 32, 33, 34, 35, 36, 37,
                                        38, 39, 40, 41, 42, 43, 44, 45, 46, 47, 48, 49, 50, 51, 52, 53};
const bool RELAY_ACTIVE_LOW = true;    // most opto-isolated relay boards close their contact on a LOW input
const uint16_t WATCHDOG_MS = 500;      // every coil off when no valid command arrives for this long
const uint16_t RELAY_SETTLE_MS = 10;   // contact bounce and release time of the relays
const char DEVICE_NAME[] = "spherestep-mega";
const unsigned long BAUD = 115200;

void writeChannel(uint8_t channel, bool on) {
  digitalWrite(CHANNEL_PINS[channel], (on != RELAY_ACTIVE_LOW) ? HIGH : LOW);
}

// Channels are split by role only through the masks: the Device never closes an enable relay while it
// moves polarity relays; the delays give the contacts time to open and settle in between.
class RelayOutputs : public spherestep::Outputs {
 public:
  void setEnable(uint64_t mask) override {
    for (uint8_t ch = 0; ch < CHANNELS; ++ch) {
      if (((enable_ ^ mask) >> ch) & 1) writeChannel(ch, (mask >> ch) & 1);
    }
    enable_ = mask;
  }
  void setPolarity(uint64_t mask) override {
    if (mask == polarity_) return;
    delay(RELAY_SETTLE_MS);  // let the enable contacts open first
    for (uint8_t ch = 0; ch < CHANNELS; ++ch) {
      if (((polarity_ ^ mask) >> ch) & 1) writeChannel(ch, (mask >> ch) & 1);
    }
    polarity_ = mask;
    delay(RELAY_SETTLE_MS);  // and the polarity contacts settle before any enable closes
  }

 private:
  uint64_t enable_ = 0;
  uint64_t polarity_ = 0;
};

RelayOutputs outputs;
spherestep::Device* device = nullptr;
char reply[spherestep::MAX_REPLY];

}  // namespace

void setup() {
  for (uint8_t ch = 0; ch < CHANNELS; ++ch) {
    writeChannel(ch, false);  // latch the off level before the pin becomes an output
    pinMode(CHANNEL_PINS[ch], OUTPUT);
  }
  // Built here rather than as a global so that its constructor (which writes every output off) runs after
  // the Arduino core is initialised and the pins are outputs.
  static spherestep::Device instance(outputs, CHANNELS, WATCHDOG_MS, DEVICE_NAME);
  device = &instance;
  Serial.begin(BAUD);
#if defined(__AVR__)
  wdt_enable(WDTO_250MS);  // a hung sketch resets the board, whose pins then float to relay-off
#endif
}

void loop() {
#if defined(__AVR__)
  wdt_reset();
#endif
  while (Serial.available() > 0) {
    size_t n = device->receive((char)Serial.read(), millis(), reply);
    if (n > 0) Serial.write(reinterpret_cast<const uint8_t*>(reply), n);
  }
  device->tick(millis());
}
