// Runs the sketch itself (spherestep.ino) on the host against the recording Arduino stand-in in arduino/:
// pins start at the relay-off level, a SET closes the right relays on the Mega's pins 22..53 (active low),
// polarity relays move only while the enable relays are open and after the settle delay, the watchdog
// opens everything. g++ -std=c++11 -Iarduino -I../spherestep test_sketch.cpp ../spherestep/protocol.cpp
#include "check.h"
#include <cstdio>
#include <string>
#include <vector>

#include "Arduino.h"
#include "spherestep.ino"

namespace {

uint8_t level[256];
bool isOutput[256];
unsigned long clockMs = 0;
std::string rx;  // bytes the host has sent, not yet read
std::string tx;  // bytes the sketch wrote
std::vector<std::string> events;


std::string frame(const std::string& body) {
  char crc[8];
  std::snprintf(crc, sizeof crc, "%04X", spherestep::crc16(body.data(), body.size()));
  return "$" + body + "*" + crc + "\n";
}

// The sketch's answer to one frame, after one pass of loop().
std::string exchange(const std::string& body) {
  rx = frame(body);
  tx.clear();
  loop();
  return tx;
}

// True when channel ch's relay is closed (pins 22.. are channels 0.., active low).
bool closed(int ch) { return isOutput[22 + ch] && level[22 + ch] == LOW; }

}  // namespace

void pinMode(uint8_t pin, uint8_t mode) {
  isOutput[pin] = mode == OUTPUT;
  events.push_back("mode " + std::to_string(pin));
}
void digitalWrite(uint8_t pin, uint8_t value) {
  level[pin] = value;
  events.push_back("pin " + std::to_string(pin) + (value == HIGH ? " high" : " low"));
}
void delay(unsigned long ms) {
  clockMs += ms;
  events.push_back("delay " + std::to_string(ms));
}
unsigned long millis() { return clockMs; }
void HardwareSerial::begin(unsigned long) {}
int HardwareSerial::available() { return static_cast<int>(rx.size()); }
int HardwareSerial::read() {
  if (rx.empty()) return -1;
  int c = static_cast<unsigned char>(rx[0]);
  rx.erase(0, 1);
  return c;
}
size_t HardwareSerial::write(const uint8_t* data, size_t length) {
  tx.append(reinterpret_cast<const char*>(data), length);
  return length;
}
HardwareSerial Serial;

int main() {
  setup();
  bool offBeforeOutput = events.size() == 64;
  for (int ch = 0; ch < 32 && offBeforeOutput; ++ch) {
    offBeforeOutput = events[2 * ch] == "pin " + std::to_string(22 + ch) + " high" &&
                      events[2 * ch + 1] == "mode " + std::to_string(22 + ch);
  }
  check(offBeforeOutput, "each pin latched high (relay off) before it becomes an output");

  check(exchange("00,HELLO,1") == frame("00,ACK,HELLO,1,32,500,spherestep-mega"), "handshake reports 32 channels");
  check(exchange("01,SET,3,0") == frame("01,ACK,SET,3,0"), "SET acknowledged");
  check(closed(0) && closed(1) && !closed(2) && !closed(16) && !closed(31), "enable relays 0 and 1 closed");

  events.clear();
  const unsigned long received = clockMs;  // the watchdog counts from the frame's arrival, before the delays
  check(exchange("02,SET,3,20000") == frame("02,ACK,SET,3,20000"), "SET with a polarity change acknowledged");
  const std::vector<std::string> expected = {"pin 22 high", "pin 23 high", "delay 10", "pin 39 low", "delay 10",
                                             "pin 22 low", "pin 23 low"};
  std::string got;
  for (const std::string& e : events) got += e + "; ";
  check(events == expected, "open enables, settle, switch polarity, settle, close enables (got " + got + ")");
  check(closed(0) && closed(1) && closed(17), "coils 0, 1 on, polarity relay 17 closed");

  clockMs = received + 499;
  loop();
  check(closed(0), "still on 499 ms after the last command");
  clockMs = received + 500;
  loop();
  bool allOpen = true;
  for (int ch = 0; ch < 32; ++ch) allOpen = allOpen && !closed(ch);
  check(allOpen, "every relay open when the watchdog expires");
  check(exchange("03,SET,1,0") == frame("03,NAK,WDOG"), "SET refused after the watchdog tripped");

  return report();
}
