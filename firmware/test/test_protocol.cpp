// Host test harness for the firmware's protocol core: g++ -std=c++11 -I../spherestep test_protocol.cpp
// ../spherestep/protocol.cpp, run with the path of vectors.txt. Prints one line per failure and a closing
// "N passed, N failed"; the exit status is 0 only if nothing failed.
#include "check.h"
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "protocol.h"

using spherestep::Device;

namespace {


std::string hex(uint64_t v) {
  char text[20];
  std::snprintf(text, sizeof text, "%llX", static_cast<unsigned long long>(v));
  return text;
}

// A reply without its line ending, for messages.
std::string shown(const std::string& reply) {
  return reply.empty() || reply.back() != '\n' ? reply : reply.substr(0, reply.size() - 1);
}

std::string frame(const std::string& body) {
  char crc[8];
  std::snprintf(crc, sizeof crc, "%04X", spherestep::crc16(body.data(), body.size()));
  return "$" + body + "*" + crc + "\n";
}

// Every output write, in order, and whether a polarity relay ever moved with an enable relay closed.
struct RecordingOutputs : spherestep::Outputs {
  uint64_t enable = 0;
  uint64_t polarity = 0;
  bool polarityMovedWhileEnabled = false;
  std::vector<std::string> writes;
  void setEnable(uint64_t mask) override {
    enable = mask;
    writes.push_back("E" + hex(mask));
  }
  void setPolarity(uint64_t mask) override {
    if (mask != polarity && enable != 0) polarityMovedWhileEnabled = true;
    polarity = mask;
    writes.push_back("P" + hex(mask));
  }
};

struct Rig {
  RecordingOutputs out;
  std::string name;
  Device device;
  uint32_t now = 0;
  std::vector<std::string> replies;
  Rig(uint8_t channels, uint16_t watchdogMs, const std::string& deviceName)
      : name(deviceName), device(out, channels, watchdogMs, name.c_str()) {}
  void send(const std::string& bytes) {
    replies.clear();
    char reply[spherestep::MAX_REPLY];
    for (char c : bytes) {
      size_t n = device.receive(c, now, reply);
      if (n > 0) replies.push_back(std::string(reply, n));
    }
  }
};

std::string unescape(const std::string& text) {
  std::string out;
  for (size_t i = 0; i < text.size(); ++i) {
    if (text[i] != '\\' || i + 1 >= text.size()) {
      out += text[i];
      continue;
    }
    char e = text[++i];
    if (e == 'n') {
      out += '\n';
    } else if (e == 'r') {
      out += '\r';
    } else if (e == 'x' && i + 2 < text.size()) {
      out += static_cast<char>(std::strtol(text.substr(i + 1, 2).c_str(), nullptr, 16));
      i += 2;
    } else {
      out += e;
    }
  }
  return out;
}

void runVectors(const char* path) {
  std::ifstream in(path);
  check(in.good(), std::string("open vectors file ") + path);
  Rig* rig = nullptr;
  size_t next = 0;  // index of the next unconsumed reply
  std::string line;
  int lineNo = 0;
  while (std::getline(in, line)) {
    ++lineNo;
    if (line.empty() || line[0] == '#') continue;
    const std::string where = std::string(path) + ":" + std::to_string(lineNo) + ": " + line;
    std::istringstream words(line);
    std::string op;
    words >> op;
    std::string rest = line.size() > op.size() ? line.substr(op.size() + 1) : "";
    if (op == "crc") {
      std::string text, expected;
      words >> text >> expected;
      check(hex(spherestep::crc16(text.data(), text.size())) == expected, where);
    } else if (op == "device") {
      int channels = 0, watchdog = 0;
      std::string name;
      words >> channels >> watchdog >> name;
      delete rig;
      rig = new Rig(static_cast<uint8_t>(channels), static_cast<uint16_t>(watchdog), name);
      next = 0;
    } else if (rig == nullptr) {
      check(false, where + " (no device line before it)");
    } else if (op == "@") {
      rig->now = static_cast<uint32_t>(std::stoul(rest));
      rig->device.tick(rig->now);
    } else if (op == ">" || op == ">raw") {
      check(next >= rig->replies.size(), where + " (previous send left a reply unchecked)");
      rig->send(op == ">" ? frame(rest) : unescape(rest));
      next = 0;
    } else if (op == "<") {
      bool have = next < rig->replies.size();
      check(have && rig->replies[next] == frame(rest),
            where + " (got " + (have ? shown(rig->replies[next]) : std::string("nothing")) + ")");
      ++next;
    } else if (op == "-") {
      check(next >= rig->replies.size(), where + " (got " +
                                             (next < rig->replies.size() ? shown(rig->replies[next]) : "") + ")");
    } else if (op == "=") {
      std::string enable, polarity;
      words >> enable >> polarity;
      check(hex(rig->device.enable()) == enable && hex(rig->device.polarity()) == polarity &&
                rig->out.enable == rig->device.enable() && rig->out.polarity == rig->device.polarity(),
            where + " (device drives " + hex(rig->out.enable) + " " + hex(rig->out.polarity) + ")");
    } else {
      check(false, where + " (unknown operation)");
    }
  }
  delete rig;
}

// Polarity relays move only with every enable relay open, and unchanged relays are not rewritten.
void testBreakBeforeMake() {
  Rig rig(32, 500, "bbm");
  rig.send(frame("00,HELLO,1"));
  rig.out.writes.clear();
  rig.send(frame("01,SET,3,0"));
  rig.send(frame("02,SET,3,2"));
  rig.send(frame("03,SET,5,2"));
  rig.send(frame("04,OFF"));
  const char* expected[] = {"E3", "E0", "P2", "E3", "E5", "E0", "P0"};
  bool same = rig.out.writes.size() == 7;
  for (size_t i = 0; same && i < 7; ++i) same = rig.out.writes[i] == expected[i];
  std::string got;
  for (const std::string& w : rig.out.writes) got += w + " ";
  check(same, "break-before-make write order (got " + got + ")");
  check(!rig.out.polarityMovedWhileEnabled, "no polarity relay moved while an enable relay was closed");
}

// The watchdog uses unsigned differences, so it works across the 49.7-day wrap of millis().
void testWatchdogAcrossMillisWrap() {
  Rig rig(8, 500, "wrap");
  rig.now = 0xFFFFFF00u;
  rig.send(frame("00,HELLO,1"));
  rig.send(frame("01,SET,1,0"));
  rig.device.tick(0xFFFFFF00u + 499u);
  check(rig.device.enable() == 1, "coil still on 499 ms after the last command across the wrap");
  rig.device.tick(0xFFFFFF00u + 500u);  // wraps to 0x000000F4
  check(rig.device.enable() == 0 && rig.device.tripped() && rig.device.trips() == 1,
        "watchdog trips 500 ms after the last command across the wrap");
}

// The device starts with every output written off, and reports its channel count in the handshake.
void testBootAndHandshake() {
  Rig rig(24, 250, "boot");
  check(rig.out.writes.size() == 2 && rig.out.writes[0] == "E0" && rig.out.writes[1] == "P0",
        "outputs written off at construction");
  rig.send(frame("7F,HELLO,1"));
  check(rig.replies.size() == 1 && rig.replies[0] == frame("7F,ACK,HELLO,1,24,250,boot"),
        "handshake reports version, 24 channels, 250 ms watchdog");
  check(rig.device.session() && !rig.device.tripped(), "session open after HELLO");
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::printf("usage: %s firmware/test/vectors.txt\n", argv[0]);
    return 2;
  }
  runVectors(argv[1]);
  testBreakBeforeMake();
  testWatchdogAcrossMillisWrap();
  testBootAndHandshake();
  return report();
}
