// Host test harness for the current-mode core: g++ -std=c++11 -I../spherestep test_drive.cpp
// ../spherestep/drive.cpp ../spherestep/protocol.cpp, run with the path of vectors2.txt. Prints one line per
// failure and a closing "N passed, N failed"; the exit status is 0 only if nothing failed.
#include "check.h"
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "drive.h"
#include "protocol.h"

using spherestep::CurrentDevice;

namespace {


std::string frame(const std::string& body) {
  char crc[8];
  std::snprintf(crc, sizeof crc, "%04X", spherestep::crc16(body.data(), body.size()));
  return "$" + body + "*" + crc + "\n";
}

std::string shown(const std::string& reply) {
  return reply.empty() || reply.back() != '\n' ? reply : reply.substr(0, reply.size() - 1);
}

std::vector<long> numbers(const std::string& text) {
  std::vector<long> out;
  std::stringstream in(text);
  std::string item;
  while (std::getline(in, item, ',')) out.push_back(std::strtol(item.c_str(), nullptr, 10));
  return out;
}

// The table plant: the sense reads what the vectors say; the bridges record what the device drives.
struct TablePlant : spherestep::Bridges {
  std::vector<long> ma;
  std::vector<long> counts;
  uint32_t stale = 0;
  std::vector<double> duty;
  bool enabled = false;
  void measure(int32_t* out) override {
    for (size_t k = 0; k < ma.size(); ++k) out[k] = static_cast<int32_t>(ma[k]);
  }
  void drive(const double* d, bool on) override {
    for (size_t k = 0; k < duty.size(); ++k) duty[k] = d[k];
    enabled = on;
  }
  uint32_t sense(int32_t* out) override {
    for (size_t k = 0; k < counts.size(); ++k) out[k] = static_cast<int32_t>(counts[k]);
    return stale;
  }
};

struct Rig {
  TablePlant plant;
  std::string name;
  CurrentDevice device;
  uint32_t now = 0;
  uint32_t period;
  std::vector<std::string> replies;
  static TablePlant& prepared(TablePlant& p, int coils, int sensors) {
    p.ma.assign(coils, 0);
    p.counts.assign(3 * sensors, 0);
    p.duty.assign(coils, 0.0);
    return p;
  }
  Rig(int coils, int sensors, int watchdog, uint32_t periodUs, const std::string& deviceName,
      const spherestep::Limits& limits)
      : name(deviceName),
        device(prepared(plant, coils, sensors), static_cast<uint8_t>(coils), static_cast<uint8_t>(sensors),
               static_cast<uint16_t>(watchdog), limits,
               spherestep::Loop{24.0, 18.7e-3, 125.0, periodUs, 1000, 8118}, name.c_str()),
        period(periodUs) {}
  void send(const std::string& bytes) {
    replies.clear();
    char reply[spherestep::MAX_REPLY2];
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
    } else {
      out += e;
    }
  }
  return out;
}

void runVectors(const char* path) {
  std::ifstream in(path);
  check(in.good(), std::string("open vectors file ") + path);
  spherestep::Limits limits{1.0, 0.95, 100.0, 1.0, 60.0, 24.0, 1.25};
  Rig* rig = nullptr;
  size_t next = 0;
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
      char got[8];
      std::snprintf(got, sizeof got, "%04X", spherestep::crc16(text.data(), text.size()));
      check(expected == got, where);
    } else if (op == "limits") {
      double ma, duty, watts, cont, thermal, res;
      words >> ma >> duty >> watts >> cont >> thermal >> res;
      limits = spherestep::Limits{ma / 1000, duty / 1000, watts, cont / 1000, thermal / 1000, res / 1000, 1.25};
    } else if (op == "device2") {
      int coils = 0, sensors = 0, watchdog = 0, periodUs = 0;
      std::string name;
      words >> coils >> sensors >> watchdog >> periodUs >> name;
      delete rig;
      rig = new Rig(coils, sensors, watchdog, static_cast<uint32_t>(periodUs), name, limits);
      limits = spherestep::Limits{1.0, 0.95, 100.0, 1.0, 60.0, 24.0, 1.25};
      next = 0;
    } else if (rig == nullptr) {
      check(false, where + " (no device2 line before it)");
    } else if (op == "meas") {
      rig->plant.ma = numbers(rest);
    } else if (op == "field") {
      std::string stale, counts;
      words >> stale >> counts;
      rig->plant.stale = static_cast<uint32_t>(std::strtoul(stale.c_str(), nullptr, 16));
      rig->plant.counts = numbers(counts);
    } else if (op == "@") {
      rig->now = static_cast<uint32_t>(std::stoul(rest));
      rig->device.tick(rig->now);
    } else if (op == "step") {
      unsigned long at = 0, count = 0;
      words >> at >> count;
      for (unsigned long i = 0; i < count; ++i) {
        rig->now = static_cast<uint32_t>(at + i * rig->period);
        rig->device.step(rig->now);
      }
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
      check(next >= rig->replies.size(), where + " (got an unexpected reply)");
    } else if (op == "=") {
      std::string what, value, coil;
      words >> what >> value >> coil;
      if (what == "duty") {
        std::vector<long> expected = numbers(value);
        std::string got;
        bool ok = expected.size() == rig->plant.duty.size();
        for (size_t k = 0; k < rig->plant.duty.size(); ++k) {
          long permille = std::lround(rig->plant.duty[k] * 1000);
          got += std::to_string(permille) + ",";
          ok = ok && k < expected.size() && expected[k] == permille;
        }
        check(ok, where + " (got " + got + ")");
      } else if (what == "enabled") {
        check(rig->plant.enabled == (value == "1") && rig->device.enabled() == (value == "1"), where);
      } else if (what == "trip") {
        const char* t = rig->device.tripped();
        if (value == "-") {
          check(t == nullptr, where + " (got " + (t ? t : "none") + ")");
        } else {
          check(t != nullptr && value == t && rig->device.tripCoil() == std::atoi(coil.c_str()),
                where + " (got " + (t ? t : "none") + " " + std::to_string(rig->device.tripCoil()) + ")");
        }
      } else {
        check(false, where + " (unknown check)");
      }
    } else {
      check(false, where + " (unknown operation)");
    }
  }
  delete rig;
}

// A 29-coil, 8-sensor state frame fits the receive and reply buffers (the prototype's size on the wire).
void testPrototypeFrameFits() {
  spherestep::Limits limits{1.0, 0.95, 100.0, 1.0, 60.0, 24.0, 1.25};
  Rig rig(29, 8, 100, 1000, "t41", limits);
  rig.send(frame("00,HELLO,2"));
  std::string block(4 * 29, '0');
  rig.send(frame("01,DRIVE," + block));
  check(rig.replies.size() == 1 && rig.replies[0].size() == 14 + 8 + 3 + 4 * 29 + 1 + 12 * 8 + 6,
        "29-coil DRIVE answered with a 244-byte state frame");
}

// The watchdog uses unsigned µs differences, so it works across the 71.6-minute wrap of micros().
void testWatchdogAcrossMicrosWrap() {
  spherestep::Limits limits{1.0, 0.95, 100.0, 1.0, 60.0, 24.0, 1.25};
  Rig rig(3, 1, 100, 1000, "wrap", limits);
  rig.now = 0xFFFFF000u;
  rig.send(frame("00,HELLO,2"));
  rig.device.tick(0xFFFFF000u + 99999u);
  check(rig.device.version() == 2, "session open 99.999 ms after the last command across the wrap");
  rig.device.tick(0xFFFFF000u + 100000u);
  check(rig.device.version() == 0 && rig.device.tripped() != nullptr, "watchdog trips across the wrap");
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::printf("usage: %s firmware/test/vectors2.txt\n", argv[0]);
    return 2;
  }
  runVectors(argv[1]);
  testPrototypeFrameFits();
  testWatchdogAcrossMicrosWrap();
  return report();
}
