// spherestep coil controller: line protocol parser and state machine. See protocol.h and docs/protocol.md.
#include "protocol.h"

namespace spherestep {

namespace {

const size_t MAX_FIELDS = 8;  // sequence, verb and up to six arguments are kept; more are only counted

int hexValue(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  return -1;
}

// A NUL-terminated field of minDigits..maxDigits hex digits and nothing else.
bool parseHex(const char* s, size_t minDigits, size_t maxDigits, uint64_t* value) {
  uint64_t v = 0;
  size_t n = 0;
  for (; s[n] != '\0'; ++n) {
    int d = hexValue(s[n]);
    if (d < 0 || n >= maxDigits) return false;
    v = (v << 4) | (uint64_t)d;
  }
  if (n < minDigits) return false;
  *value = v;
  return true;
}

// A NUL-terminated field of 1..maxDigits decimal digits and nothing else.
bool parseDecimal(const char* s, size_t maxDigits, uint32_t* value) {
  uint32_t v = 0;
  size_t n = 0;
  for (; s[n] != '\0'; ++n) {
    if (s[n] < '0' || s[n] > '9' || n >= maxDigits) return false;
    v = v * 10 + (uint32_t)(s[n] - '0');
  }
  if (n < 1) return false;
  *value = v;
  return true;
}

bool same(const char* a, const char* b) {
  while (*a != '\0' && *a == *b) {
    ++a;
    ++b;
  }
  return *a == *b;
}

const char HEX_DIGITS[] = "0123456789ABCDEF";

// Builds "$SS,..." into a caller's buffer of MAX_REPLY bytes and seals it with "*CCCC\n".
class Reply {
 public:
  Reply(char* buffer, int seq) : buf_(buffer), len_(0) {
    put('$');
    if (seq < 0) {
      put('-');
      put('-');
    } else {
      put(HEX_DIGITS[(seq >> 4) & 0xF]);
      put(HEX_DIGITS[seq & 0xF]);
    }
  }
  void field(const char* s) {
    put(',');
    while (*s != '\0') put(*s++);
  }
  void hexField(uint64_t v) {
    char digits[16];
    size_t n = 0;
    do {
      digits[n++] = HEX_DIGITS[v & 0xF];
      v >>= 4;
    } while (v != 0);
    put(',');
    while (n > 0) put(digits[--n]);
  }
  void decimalField(uint32_t v) {
    char digits[10];
    size_t n = 0;
    do {
      digits[n++] = (char)('0' + v % 10);
      v /= 10;
    } while (v != 0);
    put(',');
    while (n > 0) put(digits[--n]);
  }
  size_t finish() {
    uint16_t crc = crc16(buf_ + 1, len_ - 1);
    put('*');
    for (int shift = 12; shift >= 0; shift -= 4) put(HEX_DIGITS[(crc >> shift) & 0xF]);
    put('\n');
    buf_[len_] = '\0';
    return len_;
  }

 private:
  void put(char c) {
    if (len_ < MAX_REPLY - 1) buf_[len_++] = c;
  }
  char* buf_;
  size_t len_;
};

size_t nak(char* reply, int seq, const char* code) {
  Reply r(reply, seq);
  r.field("NAK");
  r.field(code);
  return r.finish();
}

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
      len_(0),
      inFrame_(false),
      overflow_(false),
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
  if (c == '$') {
    len_ = 0;
    inFrame_ = true;
    overflow_ = false;
    return 0;
  }
  if (!inFrame_ || c == '\r') return 0;
  if (c == '\n') {
    inFrame_ = false;
    return process(nowMs, reply);
  }
  if (len_ < MAX_FRAME) {
    buf_[len_++] = c;
  } else {
    overflow_ = true;
  }
  return 0;
}

size_t Device::process(uint32_t nowMs, char* reply) {
  tick(nowMs);
  if (overflow_) return nak(reply, -1, "FRAME");
  buf_[len_] = '\0';
  size_t star = len_;
  for (size_t i = 0; i < len_; ++i) {
    if (buf_[i] < 0x20 || buf_[i] > 0x7E) return nak(reply, -1, "FRAME");
    if (buf_[i] == '*') star = i;
  }
  uint64_t received = 0;
  if (star == len_ || !parseHex(buf_ + star + 1, 4, 4, &received)) return nak(reply, -1, "FRAME");
  if (crc16(buf_, star) != (uint16_t)received) return nak(reply, -1, "CRC");
  buf_[star] = '\0';

  const char* fields[MAX_FIELDS];
  size_t count = 1;
  fields[0] = buf_;
  for (size_t i = 0; i < star; ++i) {
    if (buf_[i] == ',') {
      buf_[i] = '\0';
      if (count < MAX_FIELDS) fields[count] = buf_ + i + 1;
      ++count;
    }
  }
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
