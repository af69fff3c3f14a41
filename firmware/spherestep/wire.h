// spherestep line protocol: the field parsers and the reply builder shared by protocol.cpp (version 1, relay
// masks) and drive.cpp (version 2, coil currents). Header-only, plain C++ without heap or standard library.
#ifndef SPHERESTEP_WIRE_H
#define SPHERESTEP_WIRE_H

#include <stddef.h>
#include <stdint.h>

namespace spherestep {

uint16_t crc16(const char* data, size_t length);  // defined in protocol.cpp

namespace wire {

const char HEX_DIGITS[] = "0123456789ABCDEF";

inline int hexValue(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  return -1;
}

// A NUL-terminated field of minDigits..maxDigits hex digits and nothing else.
inline bool parseHex(const char* s, size_t minDigits, size_t maxDigits, uint64_t* value) {
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
inline bool parseDecimal(const char* s, size_t maxDigits, uint32_t* value) {
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

inline bool same(const char* a, const char* b) {
  while (*a != '\0' && *a == *b) {
    ++a;
    ++b;
  }
  return *a == *b;
}

// Builds "$SS,..." into a caller's buffer of `capacity` bytes and seals it with "*CCCC\n".
// One frame "$<body>*<crc>\n" being received, for both protocol versions: feed() collects the bytes between '$'
// and the end of line (a '$' restarts, '\r' is ignored, overflow is remembered), and split() checks the frame
// (printable, CRC-16 of the body) and cuts the body into comma-separated fields in place.
enum FrameStatus { FRAME_OK = 0, FRAME_BAD = 1, FRAME_CRC = 2 };
const size_t MAX_FIELDS = 8;  // sequence, verb and up to six arguments are kept; more are only counted

template <size_t N, size_t MAX_FIELDS_T = MAX_FIELDS>
class FrameBuffer {
 public:
  FrameBuffer() : len_(0), inFrame_(false), overflow_(false) {}

  // true when a line has ended and a frame is ready for split()
  bool feed(char c) {
    if (c == '$') {
      len_ = 0;
      inFrame_ = true;
      overflow_ = false;
      return false;
    }
    if (!inFrame_ || c == '\r') return false;
    if (c == '\n') {
      inFrame_ = false;
      return true;
    }
    if (len_ < N) {
      buf_[len_++] = c;
    } else {
      overflow_ = true;
    }
    return false;
  }

  // fields[0..min(count, MAX_FIELDS_T)) point into the buffer; count is the number of fields in the frame
  FrameStatus split(const char** fields, size_t* count) {
    if (overflow_) return FRAME_BAD;
    buf_[len_] = '\0';
    size_t star = len_;
    for (size_t i = 0; i < len_; ++i) {
      if (buf_[i] < 0x20 || buf_[i] > 0x7E) return FRAME_BAD;
      if (buf_[i] == '*') star = i;
    }
    uint64_t received = 0;
    if (star == len_ || !parseHex(buf_ + star + 1, 4, 4, &received)) return FRAME_BAD;
    if (crc16(buf_, star) != (uint16_t)received) return FRAME_CRC;
    buf_[star] = '\0';
    size_t n = 1;
    fields[0] = buf_;
    for (size_t i = 0; i < star; ++i) {
      if (buf_[i] == ',') {
        buf_[i] = '\0';
        if (n < MAX_FIELDS_T) fields[n] = buf_ + i + 1;
        ++n;
      }
    }
    *count = n;
    return FRAME_OK;
  }

 private:
  char buf_[N + 1];
  size_t len_;
  bool inFrame_;
  bool overflow_;
};

class Reply {
 public:
  Reply(char* buffer, size_t capacity, int seq) : buf_(buffer), cap_(capacity), len_(0) {
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
  // Fixed-width upper-case hex digits of v, without a separator (blocks of 16-bit values, 8-digit clocks).
  void hexDigits(uint32_t v, int digits) {
    for (int shift = 4 * (digits - 1); shift >= 0; shift -= 4) put(HEX_DIGITS[(v >> shift) & 0xF]);
  }
  void comma() { put(','); }
  size_t finish() {
    uint16_t crc = crc16(buf_ + 1, len_ - 1);
    put('*');
    hexDigits(crc, 4);
    put('\n');
    buf_[len_] = '\0';
    return len_;
  }

 private:
  void put(char c) {
    if (len_ < cap_ - 1) buf_[len_++] = c;
  }
  char* buf_;
  size_t cap_;
  size_t len_;
};

inline size_t nak(char* reply, size_t capacity, int seq, const char* code) {
  Reply r(reply, capacity, seq);
  r.field("NAK");
  r.field(code);
  return r.finish();
}

}  // namespace wire
}  // namespace spherestep

#endif  // SPHERESTEP_WIRE_H
