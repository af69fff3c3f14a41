// spherestep coil controller: line protocol parser and state machine (docs/protocol.md).
//
// Plain C++ with no Arduino headers, no heap and no standard library beyond <stdint.h>, <stddef.h>: the
// sketch (spherestep.ino) feeds it received bytes and millis(); the host test harness
// (firmware/test/test_protocol.cpp) does the same with g++. The Python emulator
// (spherestep.hardware.CurrentDevice.relay_board) is its counterpart; both pass firmware/test/vectors.txt.
#ifndef SPHERESTEP_PROTOCOL_H
#define SPHERESTEP_PROTOCOL_H

#include <stddef.h>
#include <stdint.h>

#include "wire.h"

namespace spherestep {

const uint8_t PROTOCOL_VERSION = 1;
const size_t MAX_FRAME = 80;    // bytes between '$' and the end of line
const size_t MAX_REPLY = 100;   // longest reply, '$' to '\n' included, plus a terminating NUL
const uint8_t MAX_CHANNELS = 64;
const size_t MAX_NAME = 16;

// CRC-16/CCITT-FALSE: polynomial 0x1021, initial value 0xFFFF, no reflection, no final XOR.
uint16_t crc16(const char* data, size_t length);

// The relay outputs. Bit b of a mask is channel b. Enable relays energise coils; polarity relays reverse
// them. The device moves polarity relays only while every enable relay is open (break before make).
class Outputs {
 public:
  virtual void setEnable(uint64_t mask) = 0;
  virtual void setPolarity(uint64_t mask) = 0;

 protected:
  ~Outputs() {}
};

class Device {
 public:
  // channels: 1..64 relay channels; watchdogMs: > 0; name: 1..16 characters from [A-Za-z0-9._-].
  Device(Outputs& outputs, uint8_t channels, uint16_t watchdogMs, const char* name);

  // Feed one received byte at time nowMs. When it completes a frame, the reply (a whole line, '\n'
  // included) is written to reply, NUL-terminated, and its length returned; otherwise 0.
  // reply must hold MAX_REPLY bytes.
  size_t receive(char c, uint32_t nowMs, char* reply);

  // Watchdog: if a session is open and no command was accepted for watchdogMs, open every relay, end the
  // session and remember the trip. Call it often (every loop()); it also runs before each frame.
  void tick(uint32_t nowMs);

  uint64_t enable() const { return enable_; }
  uint64_t polarity() const { return polarity_; }
  bool session() const { return session_; }
  bool tripped() const { return tripped_; }
  uint32_t trips() const { return trips_; }

 private:
  size_t process(uint32_t nowMs, char* reply);
  void allOff();
  void apply(uint64_t enable, uint64_t polarity);

  Outputs& out_;
  uint8_t channels_;
  uint16_t watchdogMs_;
  const char* name_;
  wire::FrameBuffer<MAX_FRAME> frame_;
  uint64_t enable_;
  uint64_t polarity_;
  bool session_;
  bool tripped_;
  uint32_t trips_;
  uint32_t lastValidMs_;
};

}  // namespace spherestep

#endif  // SPHERESTEP_PROTOCOL_H
