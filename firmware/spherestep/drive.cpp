// spherestep current-mode coil controller. See drive.h and docs/protocol.md; the Python counterpart
// (spherestep/hardware/current_device.py) is written line for line alike and both pass vectors2.txt.
#include "drive.h"

#include <math.h>

#include "wire.h"

namespace spherestep {

namespace {

using wire::parseDecimal;
using wire::parseHex;
using wire::same;


class Reply : public wire::Reply {
 public:
  Reply(char* buffer, int seq) : wire::Reply(buffer, MAX_REPLY2, seq) {}
};

size_t nak(char* reply, int seq, const char* code) { return wire::nak(reply, MAX_REPLY2, seq, code); }

double clampAbs(double x, double bound) { return x > bound ? bound : (x < -bound ? -bound : x); }

int32_t clamp16(int32_t v) { return v > 32767 ? 32767 : (v < -32767 ? -32767 : v); }

// A block of exactly 4*count hex digits: signed 16-bit values (two's complement).
bool parseBlock(const char* s, size_t count, int32_t* out) {
  for (size_t k = 0; k < count; ++k) {
    int32_t v = 0;
    for (size_t d = 0; d < 4; ++d) {
      int h = wire::hexValue(s[4 * k + d]);
      if (h < 0) return false;
      v = (v << 4) | h;
    }
    out[k] = (v & 0x8000) ? v - 0x10000 : v;
  }
  return s[4 * count] == '\0';
}

size_t length(const char* s) {
  size_t n = 0;
  while (s[n] != '\0') ++n;
  return n;
}

}  // namespace

CurrentDevice::CurrentDevice(Bridges& bridges, uint8_t coils, uint8_t sensors, uint16_t watchdogMs,
                             const Limits& limits, const Loop& loop, const char* name)
    : bridges_(bridges),
      coils_(coils),
      sensors_(sensors),
      watchdogMs_(watchdogMs),
      limits_(limits),
      loop_(loop),
      name_(name),
      enable_(0),
      polarity_(0),
      enabled_(false),
      driving_(false),
      version_(0),
      tripped_(0),
      trips_(0),
      tripCoil_(-1),
      badFrames_(0),
      lastValidUs_(0) {
  const double h = loop.periodUs * 1e-6;
  kp_ = loop.bandwidth * loop.inductance / loop.supply;
  ki_ = kp_ * limits.resistance / loop.inductance * h;
  decay_ = exp(-h / limits.thermalTime);
  coilDecay_ = exp(-h * limits.resistance / loop.inductance);
  followSteps_ = (FOLLOW_MS * 1000 + loop.periodUs / 2) / loop.periodUs;
  if (followSteps_ < 1) followSteps_ = 1;
  for (uint8_t k = 0; k < MAX_COILS; ++k) heat_[k] = 0.0;
  allOff();
}

void CurrentDevice::allOff() {
  for (uint8_t k = 0; k < MAX_COILS; ++k) {
    setpoint_[k] = 0.0;
    emf_[k] = 0.0;
    integral_[k] = 0.0;
    duty_[k] = 0.0;
    expected_[k] = 0.0;
    follow_[k] = 0;
    ref_[k] = 0.0;
    low_[k] = 0.0;
    high_[k] = 0.0;
    held_[k] = 0;
  }
  told_ = false;
  emfUs_ = 0;
  fresh_ = true;
  enable_ = 0;
  polarity_ = 0;
  enabled_ = false;
  driving_ = false;
  bridges_.drive(duty_, false);
}

void CurrentDevice::trip(const char* code, int coil) {
  allOff();
  version_ = 0;
  tripped_ = code;
  tripCoil_ = coil;
  ++trips_;
}

void CurrentDevice::tick(uint32_t nowUs) {
  if (session() && (uint32_t)(nowUs - lastValidUs_) >= (uint32_t)watchdogMs_ * 1000u) trip("WDOG", -1);
}

void CurrentDevice::step(uint32_t nowUs) {
  tick(nowUs);
  int32_t ma[MAX_COILS];
  bridges_.measure(ma);
  double amps[MAX_COILS];
  for (uint8_t k = 0; k < coils_; ++k) {
    amps[k] = ma[k] / 1000.0;
    const double x = amps[k] / limits_.continuousCurrent;
    heat_[k] = decay_ * heat_[k] + (1.0 - decay_) * (x * x);
  }
  if (!session() || !driving_) return;
  const double overMa = limits_.tripRatio * limits_.maxCurrent * 1000;
  for (uint8_t k = 0; k < coils_; ++k) {
    if ((ma[k] < 0 ? -ma[k] : ma[k]) > overMa) return trip("OVER", k);
  }
  for (uint8_t k = 0; k < coils_; ++k) {
    if (heat_[k] > 1.0) return trip("HEAT", k);
  }
  const double dmax = limits_.maxDuty;
  const bool told = told_ && (uint32_t)(nowUs - emfUs_) < EMF_MS * 1000u;
  for (uint8_t k = 0; k < coils_; ++k) {
    // the coil's law: the duty driven over the last period less the back-EMF, through the coil's L/R (from the
    // reading at the start, and again once a fresh estimate arrives)
    const double a = coilDecay_;
    expected_[k] = (fresh_ || !told)
                       ? amps[k]
                       : a * expected_[k] + (1.0 - a) * (duty_[k] * loop_.supply - emf_[k]) / limits_.resistance;
    const double e = setpoint_[k] - amps[k];
    integral_[k] = clampAbs(integral_[k] + ki_ * e, dmax);
    duty_[k] = clampAbs(kp_ * e + integral_[k] + emf_[k] / loop_.supply, dmax);  // PI plus the back-EMF fed forward
    // the reading off its setpoint (the loop is not doing its job); an idle coil (under 50 mA) at its setpoint is
    // never judged by the law, whose estimate may be wrong
    const bool off = fabs(e) > FOLLOW_A + FOLLOW_REL * fabs(setpoint_[k]);
    const bool judged = off || (ma[k] < 0 ? -ma[k] : ma[k]) >= 50;
    const bool offLaw = told && judged && fabs(amps[k] - expected_[k]) > FOLLOW_A + FOLLOW_REL * fabs(expected_[k]);
    follow_[k] = offLaw ? follow_[k] + 1 : 0;
    // the held reading: off its setpoint, unmoved while the loop's own duty swept (whatever the back-EMF)
    const double loopDuty = duty_[k] - emf_[k] / loop_.supply;
    const double band = FOLLOW_A + FOLLOW_REL * fabs(ref_[k]);
    const bool held = !fresh_ && off && fabs(amps[k] - ref_[k]) <= band;
    low_[k] = held && low_[k] < loopDuty ? low_[k] : loopDuty;
    high_[k] = held && high_[k] > loopDuty ? high_[k] : loopDuty;
    const bool swept = held && (fabs(duty_[k]) >= dmax || fabs(integral_[k]) >= dmax) &&
                       (high_[k] - low_[k]) * loop_.supply > SWEEP * band * limits_.resistance;
    held_[k] = swept ? held_[k] + 1 : 0;
    if (!held) ref_[k] = amps[k];
  }
  fresh_ = false;
  for (uint8_t k = 0; k < coils_; ++k) {
    if (follow_[k] >= followSteps_ || held_[k] >= followSteps_) {
      return trip((ma[k] < 0 ? -ma[k] : ma[k]) < 50 ? "OPEN" : "STUCK", k);
    }
  }
  enabled_ = true;
  bridges_.drive(duty_, true);
}

size_t CurrentDevice::receive(char c, uint32_t nowUs, char* reply) {
  return frame_.feed(c) ? process(nowUs, reply) : 0;
}

size_t CurrentDevice::damaged(const char* code, uint32_t nowUs, char* reply) {
  (void)nowUs;
  if (badFrames_ < 255) ++badFrames_;
  if (session() && badFrames_ >= CRC_STORM) trip("CRCS", -1);
  return nak(reply, -1, code);
}

bool CurrentDevice::setMa(const int32_t* ma, const int32_t* emfCv) {
  double amps[MAX_COILS];
  double power = 0.0;
  for (uint8_t k = 0; k < coils_; ++k) {
    if ((ma[k] < 0 ? -ma[k] : ma[k]) > limits_.maxCurrent * 1000) return false;
    amps[k] = ma[k] / 1000.0;
  }
  for (uint8_t k = 0; k < coils_; ++k) power += amps[k] * amps[k];
  if (limits_.resistance * power > limits_.maxPower) return false;
  for (uint8_t k = 0; k < coils_; ++k) {
    setpoint_[k] = amps[k];
    emf_[k] = emfCv ? emfCv[k] / 100.0 : 0.0;
  }
  driving_ = true;
  return true;
}

size_t CurrentDevice::state(const char* verb, int seq, uint32_t nowUs, char* reply) {
  int32_t counts[3 * MAX_SENSORS];
  int32_t ma[MAX_COILS];
  const uint32_t stale = bridges_.sense(counts);
  bridges_.measure(ma);
  Reply r(reply, seq);
  r.field("ACK");
  r.field(verb);
  r.comma();
  r.hexDigits(nowUs, 8);
  r.hexField(stale);
  r.comma();
  for (uint8_t k = 0; k < coils_; ++k) r.hexDigits((uint32_t)clamp16(ma[k]) & 0xFFFF, 4);
  r.comma();
  for (uint8_t k = 0; k < 3 * sensors_; ++k) r.hexDigits((uint32_t)clamp16(counts[k]) & 0xFFFF, 4);
  return r.finish();
}

size_t CurrentDevice::process(uint32_t nowUs, char* reply) {
  tick(nowUs);
  const char* fields[wire::MAX_FIELDS];
  size_t count = 0;
  const wire::FrameStatus status = frame_.split(fields, &count);
  if (status != wire::FRAME_OK) return damaged(status == wire::FRAME_CRC ? "CRC" : "FRAME", nowUs, reply);
  if (count < 2 || fields[1][0] == '\0') return damaged("FRAME", nowUs, reply);
  uint64_t seq64 = 0;
  if (!parseHex(fields[0], 2, 2, &seq64)) return damaged("FRAME", nowUs, reply);
  badFrames_ = 0;
  const int s = (int)seq64;
  const char* verb = fields[1];
  const size_t nargs = count - 2;
  const char* const* args = fields + 2;
  const char* refusal = tripped_ ? tripped_ : "SESSION";

  if (same(verb, "HELLO")) {
    uint32_t version = 0;
    if (nargs != 1 || !parseDecimal(args[0], 3, &version)) return nak(reply, s, "ARGS");
    if ((version != 1 && version != DRIVE_VERSION) || (version == 1 && 2 * coils_ > 64)) {
      return nak(reply, s, "VERSION");
    }
    for (uint8_t k = 0; k < coils_; ++k) {
      if (heat_[k] > 0.9) return nak(reply, s, "HEAT");
    }
    allOff();
    version_ = (uint8_t)version;
    tripped_ = 0;
    lastValidUs_ = nowUs;
    Reply r(reply, s);
    r.field("ACK");
    r.field("HELLO");
    if (version == 1) {
      r.decimalField(1);
      r.decimalField(2u * coils_);
      r.decimalField(watchdogMs_);
    } else {
      r.decimalField(DRIVE_VERSION);
      r.decimalField(coils_);
      r.decimalField(sensors_);
      r.decimalField(watchdogMs_);
      r.decimalField(loop_.periodUs);
      r.decimalField((uint32_t)lround(limits_.maxCurrent * 1000));
      r.decimalField((uint32_t)lround(limits_.maxPower));
      r.decimalField(loop_.fieldLsbNt);
      r.decimalField((uint32_t)lround(loop_.supply * 1000));         // mV
      r.decimalField((uint32_t)lround(limits_.resistance * 1000));   // mΩ
      r.decimalField((uint32_t)lround(loop_.inductance * 1e6));      // µH
      r.hexField(CAP_EMF);                                             // capabilities
    }
    r.field(name_);
    return r.finish();
  }
  if (same(verb, "OFF")) {
    if (nargs != 0) return nak(reply, s, "ARGS");
    const bool v2 = version_ == DRIVE_VERSION;
    allOff();
    if (session()) lastValidUs_ = nowUs;
    Reply r(reply, s);
    r.field("ACK");
    r.field("OFF");
    if (!v2) {
      r.hexField(0);
      r.hexField(0);
    }
    return r.finish();
  }
  if (same(verb, "PING")) {
    if (nargs != 0) return nak(reply, s, "ARGS");
    if (!session()) return nak(reply, s, refusal);
    lastValidUs_ = nowUs;
    Reply r(reply, s);
    r.field("ACK");
    r.field("PING");
    if (version_ == 1) {
      r.hexField(enable_);
      r.hexField(polarity_);
    }
    return r.finish();
  }
  if (same(verb, "SET")) {
    uint64_t enable = 0;
    uint64_t polarity = 0;
    if (nargs != 2 || !parseHex(args[0], 1, 16, &enable) || !parseHex(args[1], 1, 16, &polarity)) {
      return nak(reply, s, "ARGS");
    }
    if (version_ != 1) return nak(reply, s, version_ == DRIVE_VERSION ? "VERB" : refusal);
    const unsigned channels = 2u * coils_;
    if (channels < 64 && ((enable | polarity) >> channels) != 0) return nak(reply, s, "RANGE");
    int32_t ma[MAX_COILS];
    for (uint8_t k = 0; k < coils_; ++k) {
      const bool on = (enable >> k) & 1u;
      const bool reversed = (polarity >> (coils_ + k)) & 1u;
      ma[k] = on ? (reversed ? -loop_.nominalMa : loop_.nominalMa) : 0;
    }
    if (!setMa(ma, 0)) return nak(reply, s, "LIMIT");
    enable_ = enable;
    polarity_ = polarity;
    lastValidUs_ = nowUs;
    Reply r(reply, s);
    r.field("ACK");
    r.field("SET");
    r.hexField(enable_);
    r.hexField(polarity_);
    return r.finish();
  }
  const bool isDrive = same(verb, "DRIVE");
  if (isDrive || same(verb, "READ")) {
    int32_t ma[MAX_COILS];
    int32_t emfCv[MAX_COILS];
    if (isDrive && (nargs < 1 || nargs > 2 || length(args[0]) != 4u * coils_ || !parseBlock(args[0], coils_, ma) ||
                    (nargs == 2 && (length(args[1]) != 4u * coils_ || !parseBlock(args[1], coils_, emfCv))))) {
      return nak(reply, s, "ARGS");
    }
    if (!isDrive && nargs != 0) return nak(reply, s, "ARGS");
    if (version_ != DRIVE_VERSION) return nak(reply, s, version_ == 1 ? "VERB" : refusal);
    if (isDrive && !setMa(ma, nargs == 2 ? emfCv : 0)) return nak(reply, s, "LIMIT");
    if (isDrive) {
      told_ = nargs == 2;
      emfUs_ = nowUs;
    }
    lastValidUs_ = nowUs;
    return state(verb, s, nowUs, reply);
  }
  return nak(reply, s, "VERB");
}

}  // namespace spherestep
