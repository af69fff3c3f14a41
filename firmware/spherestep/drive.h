// spherestep current-mode coil controller: protocol version 2 (coil currents, sensor state) with version 1
// (relay masks) kept for plans, the PI current loops and the device-side limits (docs/protocol.md).
//
// Plain C++ with no Arduino headers and no heap, like protocol.h: the board sketch
// (firmware/spherestep_drive/spherestep_drive.ino) implements Bridges and feeds bytes and micros(); the host
// harness (firmware/test/test_drive.cpp) does the same with g++. The Python counterpart is
// spherestep.hardware.current_device.CurrentDevice; both pass firmware/test/vectors2.txt.
#ifndef SPHERESTEP_DRIVE_H
#define SPHERESTEP_DRIVE_H

#include <stddef.h>
#include <stdint.h>

#include "wire.h"

namespace spherestep {

uint16_t crc16(const char* data, size_t length);  // protocol.cpp: CRC-16/CCITT-FALSE

const uint8_t DRIVE_VERSION = 2;
const size_t MAX_FRAME2 = 400;  // bytes between '$' and the end of line
const size_t MAX_REPLY2 = 420;  // longest reply, '$' to '\n', plus a terminating NUL
const uint8_t CAP_EMF = 1;       // capability bit in HELLO,2's answer: DRIVE takes each coil's back-EMF (10 mV)
const uint8_t MAX_COILS = 32;
const uint8_t MAX_SENSORS = 16;
const uint8_t CRC_STORM = 8;     // damaged frames in a row that trip a session
const uint32_t FOLLOW_MS = 20;   // a reading off the coil's law (FOLLOW_A + FOLLOW_REL |i_expected|) this long: trip
const double FOLLOW_A = 0.05;    // A: the absolute part of that tolerance (sense noise and offset)
const double FOLLOW_REL = 0.1;   // the relative part (the winding's R with temperature, the back-EMF)
const uint32_t EMF_MS = FOLLOW_MS;  // a back-EMF estimate is fresh this long after its DRIVE
const double SWEEP = 2.0;        // held reading: the loop's duty swept SWEEP tolerances' worth of current (x R/V)

// Limits in SI (A, W, Ω, s), enforced on the device (hardware/limits.py CurrentLimits).
struct Limits {
  double maxCurrent;
  double maxDuty;
  double maxPower;
  double continuousCurrent;
  double thermalTime;
  double resistance;
  double tripRatio;
};

// The current loop: supply V, coil inductance H, closed-loop bandwidth rad/s, control period µs; the current of
// a relay-mode coil (mA) and the magnetometers' nT per count (reported in the handshake).
struct Loop {
  double supply;
  double inductance;
  double bandwidth;
  uint32_t periodUs;
  int32_t nominalMa;
  uint32_t fieldLsbNt;
};

// The board: one H-bridge with a current sense per coil, and the magnetometers.
class Bridges {
 public:
  virtual void measure(int32_t* ma) = 0;                    // coil currents now, mA, one per coil
  virtual void drive(const double* duty, bool enabled) = 0;  // duties in [-1, 1]; !enabled: asleep, supply cut
  virtual uint32_t sense(int32_t* counts) = 0;               // 3 counts per sensor (x y z); returns the stale mask

 protected:
  ~Bridges() {}
};

class CurrentDevice {
 public:
  // coils 1..32, sensors 0..16, watchdogMs > 0, name 1..16 characters from [A-Za-z0-9._-].
  CurrentDevice(Bridges& bridges, uint8_t coils, uint8_t sensors, uint16_t watchdogMs, const Limits& limits,
                const Loop& loop, const char* name);

  // Feed one received byte at nowUs; when it completes a frame the reply (a whole line) is written to reply
  // (MAX_REPLY2 bytes), NUL-terminated, and its length returned; otherwise 0.
  size_t receive(char c, uint32_t nowUs, char* reply);
  // Watchdog only (also run before every frame and every step).
  void tick(uint32_t nowUs);
  // One control period: read the currents, update the heat, run the PI loops, check the limits, drive.
  void step(uint32_t nowUs);

  uint8_t version() const { return version_; }  // 0 no session, 1 relay session, 2 current session
  const char* tripped() const { return tripped_; }  // trip code, or 0
  uint32_t trips() const { return trips_; }
  int tripCoil() const { return tripCoil_; }
  double duty(uint8_t k) const { return duty_[k]; }
  double setpoint(uint8_t k) const { return setpoint_[k]; }
  double heat(uint8_t k) const { return heat_[k]; }
  bool enabled() const { return enabled_; }

 private:
  size_t process(uint32_t nowUs, char* reply);
  size_t damaged(const char* code, uint32_t nowUs, char* reply);
  size_t state(const char* verb, int seq, uint32_t nowUs, char* reply);
  bool setMa(const int32_t* ma, const int32_t* emfCv);
  void allOff();
  void trip(const char* code, int coil);
  bool session() const { return version_ != 0; }

  Bridges& bridges_;
  uint8_t coils_;
  uint8_t sensors_;
  uint16_t watchdogMs_;
  Limits limits_;
  Loop loop_;
  const char* name_;
  double kp_;
  double ki_;
  double decay_;
  double coilDecay_;  // e^(-R h / L): the coil's own response over one period
  uint32_t followSteps_;
  double setpoint_[MAX_COILS];
  double emf_[MAX_COILS];  // V: each coil's back-EMF as the host last estimated it (0 without one)
  double integral_[MAX_COILS];
  double duty_[MAX_COILS];
  double heat_[MAX_COILS];
  double expected_[MAX_COILS];  // A: the current the coil's law predicts from the duties driven
  uint32_t follow_[MAX_COILS];
  double ref_[MAX_COILS];   // A: the reading the held-reading rule compares with
  double low_[MAX_COILS];   // the loop's duty d - e/V, lowest and highest since the reading was ref_
  double high_[MAX_COILS];
  uint32_t held_[MAX_COILS];  // steps held since the sweep passed SWEEP tolerances
  bool told_;       // a back-EMF estimate came with the last DRIVE
  uint32_t emfUs_;  // when it came
  bool fresh_;  // the next driving step starts expected_ at the reading (the bridges were asleep)
  uint64_t enable_;
  uint64_t polarity_;
  bool enabled_;
  bool driving_;  // setpoints taken since the last all-off: the PI loops and monitors run
  uint8_t version_;
  const char* tripped_;
  uint32_t trips_;
  int tripCoil_;
  uint8_t badFrames_;
  uint32_t lastValidUs_;
  wire::FrameBuffer<MAX_FRAME2> frame_;
};

}  // namespace spherestep

#endif  // SPHERESTEP_DRIVE_H
