// spherestep coil controller: line protocol parser and state machine. See protocol.h and docs/protocol.md.
#include "protocol.h"

#include "wire.h"

namespace spherestep {

namespace {

using wire::parseDecimal;
using wire::parseHex;
using wire::same;


class Reply : public wire::Reply {
 public:
  Reply(char* buffer, int seq) : wire::Reply(buffer, MAX_REPLY, seq) {}
};

size_t nak(char* reply, int seq, const char* code) { return wire::nak(reply, MAX_REPLY, seq, code); }

}  // namespace

uint16_t crc16(const char* data, size_t length) {
  uint16_t crc = 0xFFFF;
  for (size_t i = 0; i < length; ++i) {
    crc ^= (uint16_t)((uint8_t)data[i]) << 8;
    for (int bit = 0; bit < 8; ++bit) {
      crc = (crc & 0x8000) ? (uint16_t)((crc << 1) ^ 0x1021) : (uint16_t)(crc << 1);
    }
  }
  return crc;
}

Device::Device(Outputs& outputs, uint8_t channels, uint16_t watchdogMs, const char* name)
    : out_(outputs),
      channels_(channels),
      watchdogMs_(watchdogMs),
      name_(name),
      enable_(0),
      polarity_(0),
      session_(false),
      tripped_(false),
      trips_(0),
      lastValidMs_(0) {
  allOff();
}

void Device::allOff() {
  out_.setEnable(0);
  enable_ = 0;
  out_.setPolarity(0);
  polarity_ = 0;
}

void Device::apply(uint64_t enable, uint64_t polarity) {
  if (polarity != polarity_) {
    if (enable_ != 0) {
      out_.setEnable(0);
      enable_ = 0;
    }
    out_.setPolarity(polarity);
    polarity_ = polarity;
  }
  if (enable != enable_) {
    out_.setEnable(enable);
    enable_ = enable;
  }
}

void Device::tick(uint32_t nowMs) {
  if (session_ && (uint32_t)(nowMs - lastValidMs_) >= watchdogMs_) {
    allOff();
    session_ = false;
    tripped_ = true;
    ++trips_;
  }
}

size_t Device::receive(char c, uint32_t nowMs, char* reply) {
  return frame_.feed(c) ? process(nowMs, reply) : 0;
}

size_t Device::process(uint32_t nowMs, char* reply) {
  tick(nowMs);
  const char* fields[wire::MAX_FIELDS];
  size_t count = 0;
  const wire::FrameStatus status = frame_.split(fields, &count);
  if (status != wire::FRAME_OK) return nak(reply, -1, status == wire::FRAME_CRC ? "CRC" : "FRAME");
  if (count < 2 || fields[1][0] == '\0') return nak(reply, -1, "FRAME");
  uint64_t seq = 0;
  if (!parseHex(fields[0], 2, 2, &seq)) return nak(reply, -1, "FRAME");
  const int s = (int)seq;
  const char* verb = fields[1];
  const size_t nargs = count - 2;
  const char* const* args = fields + 2;

  if (same(verb, "HELLO")) {
    uint32_t version = 0;
    if (nargs != 1 || !parseDecimal(args[0], 3, &version)) return nak(reply, s, "ARGS");
    if (version != PROTOCOL_VERSION) return nak(reply, s, "VERSION");
    allOff();
    session_ = true;
    tripped_ = false;
    lastValidMs_ = nowMs;
    Reply r(reply, s);
    r.field("ACK");
    r.field("HELLO");
    r.decimalField(PROTOCOL_VERSION);
    r.decimalField(channels_);
    r.decimalField(watchdogMs_);
    r.field(name_);
    return r.finish();
  }
  if (same(verb, "SET")) {
    uint64_t enable = 0;
    uint64_t polarity = 0;
    if (nargs != 2 || !parseHex(args[0], 1, 16, &enable) || !parseHex(args[1], 1, 16, &polarity)) {
      return nak(reply, s, "ARGS");
    }
    if (!session_) return nak(reply, s, tripped_ ? "WDOG" : "SESSION");
    if (channels_ < 64 && ((enable | polarity) >> channels_) != 0) return nak(reply, s, "RANGE");
    apply(enable, polarity);
    lastValidMs_ = nowMs;
    Reply r(reply, s);
    r.field("ACK");
    r.field("SET");
    r.hexField(enable_);
    r.hexField(polarity_);
    return r.finish();
  }
  if (same(verb, "OFF")) {
    if (nargs != 0) return nak(reply, s, "ARGS");
    allOff();
    if (session_) lastValidMs_ = nowMs;
    Reply r(reply, s);
    r.field("ACK");
    r.field("OFF");
    r.hexField(0);
    r.hexField(0);
    return r.finish();
  }
  if (same(verb, "PING")) {
    if (nargs != 0) return nak(reply, s, "ARGS");
    if (!session_) return nak(reply, s, tripped_ ? "WDOG" : "SESSION");
    lastValidMs_ = nowMs;
    Reply r(reply, s);
    r.field("ACK");
    r.field("PING");
    r.hexField(enable_);
    r.hexField(polarity_);
    return r.finish();
  }
  return nak(reply, s, "VERB");
}

}  // namespace spherestep
