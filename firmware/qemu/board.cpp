// spherestep's coil controller on QEMU's mps2-an500 (a Cortex-M7): the board layer for the emulator, as
// spherestep_drive.ino is the Teensy 4.1's. The same drive.cpp and protocol.cpp run here; only the pins differ:
//
// * UART0 (CMSDK APB UART, 0x40004000) is the host link: protocol version 2 (docs/protocol.md), as the Teensy's
//   USB serial. QEMU maps it to a pseudo-terminal (-serial pty) that the host's DriveLink opens like a USB port.
// * The board's "pins" are a host-side coil and motor model (spherestep.hardware.qemu): the coil currents the
//   ADCs would read, the duties the PWM would drive and the magnetometer counts live in the board's PSRAM
//   (0x60000000), which QEMU backs with a file the model maps too (Exchange below); UART1 (0x40005000) carries
//   one-byte doorbells: model -> board 'C' (configure from the exchange; answered 'R'), 'T' (the currents and
//   the time are in: run one control step; answered 'D'), 'W' (the time is in: the watchdog only; answered
//   'D'), 'F' (the counts asked for are in); board -> model 'S' (a reply wants the magnetometers now), 'D' (the
//   duties and state are out). One byte each way per control step: QEMU's CMSDK UART takes one received byte at
//   a time, each a hand-over between QEMU's threads (0.1-0.2 ms on a loaded 2-core machine), too slow for a
//   29-coil frame 4000 times a second; memory is not.
// * The board's time is the model's: every frame on UART0 is taken at the time of the last 'T' or 'W'.
// * SysTick (the core's clock) runs around each control step that drives the coils; the exchange holds the count
//   of such steps and their summed and largest SysTick counts, and the count of a 100002-instruction loop run at
//   configuration, so that the host turns counts into instructions (under -icount an instruction is 2^shift ns).
//
// Between bytes the core sleeps: WFI with the UARTs' receive interrupts enabled and PRIMASK set (a pending
// interrupt ends WFI, no handler runs). Under -icount QEMU's I/O thread delivers a byte only while the core is
// halted: a core that polled the UARTs (or spun between polls) was 5-10 times slower per byte, measured.
// Build: spherestep.hardware.qemu.build_firmware.
#include <stddef.h>
#include <stdint.h>

#include "drive.h"

// placement new (no <new>: no C++ library on this board)
void* operator new(size_t, void* where) noexcept { return where; }

namespace {

volatile uint32_t& reg(uint32_t address) { return *reinterpret_cast<volatile uint32_t*>(address); }

const uint32_t UART0 = 0x40004000u;
const uint32_t UART1 = 0x40005000u;
const uint32_t DATA = 0x00, STATE = 0x04, CTRL = 0x08, INTSTATUS = 0x0C, BAUDDIV = 0x10;
const uint32_t TX_FULL = 1u, RX_FULL = 2u;
const uint32_t SYST_CSR = 0xE000E010u, SYST_RVR = 0xE000E014u, SYST_CVR = 0xE000E018u;
const uint32_t NVIC_ISER0 = 0xE000E100u, NVIC_ICPR0 = 0xE000E280u, CPACR = 0xE000ED88u;

// The exchange with the model, at the start of PSRAM (spherestep/hardware/qemu.py has the same layout).
struct Exchange {
  // model -> board, read at 'C'
  uint32_t coils, sensors, watchdogMs, periodUs;
  int32_t nominalMa;
  uint32_t fieldLsbNt;
  double limits[7];  // max current, max duty, max power, continuous current, thermal time, resistance, trip ratio
  double loop[3];    // supply, inductance, bandwidth
  char name[20];     // NUL-terminated
  // model -> board, read at 'T' (nowUs also at 'W') and 'F'
  uint32_t nowUs;
  uint32_t stale;
  int32_t ma[spherestep::MAX_COILS];
  int32_t counts[3 * spherestep::MAX_SENSORS];
  // board -> model, written before 'D' and 'R'
  uint32_t enabled, version, trip, tripCoil, trips;
  float duty[spherestep::MAX_COILS];
  uint32_t steps, maxTicks;
  uint64_t sumTicks;
  uint32_t calibration;  // SysTick counts of a 100002-instruction loop
  char build[108];
  uint32_t received;  // bytes taken from UART0 (the host link), each after its reply (if any) went out
  uint32_t answered;  // bytes put on UART0
  uint32_t tripUs;    // the board's time at the last trip
  uint32_t offUs;     // the board's time when the bridges last went from driven to off
};
Exchange& shared() { return *reinterpret_cast<Exchange*>(0x60000000u); }

void uartInit(uint32_t base) {
  reg(base + BAUDDIV) = 16;
  reg(base + CTRL) = 1u | 2u | 8u;  // TX enable, RX enable, RX interrupt (its pending line ends WFI)
}
bool readable(uint32_t base) { return (reg(base + STATE) & RX_FULL) != 0; }
// A doorbell orders the exchange: nothing in it is read before the byte that says it is in, or written after the
// byte that says it is out (a compiler barrier; the exchange is ordinary memory)
uint8_t getByte(uint32_t base) {
  const uint8_t b = (uint8_t)reg(base + DATA);
  __asm__ volatile("" ::: "memory");
  return b;
}
void putByte(uint32_t base, uint8_t b) {
  __asm__ volatile("" ::: "memory");
  while (reg(base + STATE) & TX_FULL) {
  }
  reg(base + DATA) = b;
}

// Sleep until either UART has a byte: clear the UARTs' interrupt lines, then the NVIC's pending bits, then WFI
// unless a byte came meanwhile.
void idle() {
  reg(UART0 + INTSTATUS) = 3u;
  reg(UART1 + INTSTATUS) = 3u;
  reg(NVIC_ICPR0) = 0xFu;  // UART0 and UART1, RX and TX (IRQ 0-3 on this machine)
  if (!readable(UART0) && !readable(UART1)) __asm__ volatile("wfi");
}

void startTicks() {
  reg(SYST_RVR) = 0xFFFFFFu;
  reg(SYST_CVR) = 0;
  reg(SYST_CSR) = 5u;  // processor clock, enabled, no interrupt
}
uint32_t stopTicks() {
  const uint32_t ticks = 0xFFFFFFu - reg(SYST_CVR);
  reg(SYST_CSR) = 0;  // stopped: a running SysTick would keep waking the idle core
  return ticks;
}

uint32_t nowUs = 0;  // the board's time: the model's, at its last 'T' or 'W'

class Board : public spherestep::Bridges {
 public:
  uint8_t coils = 0;
  uint8_t sensors = 0;
  uint8_t deferred = 0;  // a doorbell that rang while a reply waited for the magnetometers
  double duty[spherestep::MAX_COILS] = {0};
  bool enabled = false;

  void measure(int32_t* ma) override {
    for (uint8_t k = 0; k < coils; ++k) ma[k] = shared().ma[k];
  }
  void drive(const double* d, bool on) override {
    for (uint8_t k = 0; k < coils; ++k) duty[k] = on ? d[k] : 0.0;
    if (enabled && !on) shared().offUs = nowUs;
    enabled = on;
  }
  uint32_t sense(int32_t* counts) override {
    putByte(UART1, 'S');
    for (;;) {
      if (!readable(UART1)) {
        idle();
        continue;
      }
      const uint8_t b = getByte(UART1);
      if (b == 'F') break;
      deferred = b;  // the model rang before it saw 'S'; it waits for this one's answer, so one is enough
    }
    for (uint8_t i = 0; i < 3 * sensors; ++i) counts[i] = shared().counts[i];
    return shared().stale;
  }
};

const char* const TRIPS[] = {"WDOG", "CRCS", "OVER", "OPEN", "STUCK", "HEAT"};

Board board;
alignas(8) uint8_t deviceStorage[sizeof(spherestep::CurrentDevice)];
spherestep::CurrentDevice* device = nullptr;
char name[17];
char reply[spherestep::MAX_REPLY2];

bool same(const char* a, const char* b) {
  while (*a && *a == *b) ++a, ++b;
  return *a == *b;
}

// The board's state into the exchange: after every step and tick (then 'D') and after every frame.
void record() {
  Exchange& x = shared();
  x.enabled = board.enabled;
  x.version = device->version();
  x.trip = 0;
  for (uint32_t i = 0; device->tripped() && i < 6; ++i) {
    if (same(TRIPS[i], device->tripped())) x.trip = i + 1;
  }
  x.tripCoil = (uint32_t)device->tripCoil();
  if (device->trips() != x.trips) x.tripUs = nowUs;
  x.trips = device->trips();
  for (uint8_t k = 0; k < board.coils; ++k) x.duty[k] = (float)board.duty[k];
}

void configure() {
  Exchange& x = shared();
  board.coils = (uint8_t)x.coils;
  board.sensors = (uint8_t)x.sensors;
  for (int i = 0; i < 16; ++i) name[i] = x.name[i];
  name[16] = '\0';
  const spherestep::Limits limits = {x.limits[0], x.limits[1], x.limits[2], x.limits[3],
                                     x.limits[4], x.limits[5], x.limits[6]};
  const spherestep::Loop loop = {x.loop[0], x.loop[1], x.loop[2], x.periodUs, x.nominalMa, x.fieldLsbNt};
  device = new (deviceStorage) spherestep::CurrentDevice(board, board.coils, board.sensors, (uint16_t)x.watchdogMs,
                                                         limits, loop, name);
  startTicks();
  uint32_t n = 50000;
  __asm__ volatile("1: subs %0, %0, #1\n bne 1b" : "+r"(n));  // with the mov before and the read after: 100002
  x.calibration = stopTicks();
  static const char build[] = "drive.cpp on mps2-an500, arm-none-eabi-g++ " __VERSION__;
  for (size_t i = 0; i < sizeof build && i < sizeof x.build; ++i) x.build[i] = build[i];
  x.steps = x.maxTicks = 0;
  x.sumTicks = 0;
  putByte(UART1, 'R');
}

void ring(uint8_t doorbell) {
  if (doorbell == 'C') {
    if (device == nullptr) configure();
    return;
  }
  if (device == nullptr) return;
  Exchange& x = shared();
  nowUs = x.nowUs;
  if (doorbell == 'W') {
    device->tick(nowUs);
  } else if (doorbell == 'T') {
    startTicks();
    device->step(nowUs);
    const uint32_t ticks = stopTicks();
    if (device->enabled()) {  // a step that ran the PI loops and drove
      ++x.steps;
      x.sumTicks += ticks;
      if (ticks > x.maxTicks) x.maxTicks = ticks;
    }
  } else {
    return;  // 'F' outside a request: stale, dropped
  }
  record();
  putByte(UART1, 'D');
}

}  // namespace

int main() {
  uartInit(UART0);
  uartInit(UART1);
  reg(NVIC_ISER0) = 0xFu;
  for (;;) {
    if (board.deferred) {
      const uint8_t b = board.deferred;
      board.deferred = 0;
      ring(b);
    } else if (readable(UART1)) {
      ring(getByte(UART1));
    } else if (device != nullptr && readable(UART0)) {
      const size_t n = device->receive((char)getByte(UART0), nowUs, reply);
      for (size_t i = 0; i < n; ++i) putByte(UART0, (uint8_t)reply[i]);
      if (n > 0) record();  // a frame may have switched the bridges off or tripped
      shared().answered += n;
      ++shared().received;
    } else {
      idle();
    }
  }
}

extern "C" {
// static objects register their destructors; a firmware never exits, so nothing is kept
void* __dso_handle = nullptr;
int __cxa_atexit(void (*)(void*), void*, void*) { return 0; }

extern uint32_t __data_load, __data_start, __data_end, __bss_start, __bss_end, __stack_top;
extern void (*__init_array_start[])();
extern void (*__init_array_end[])();

[[noreturn]] void reset() {
  reg(CPACR) |= 0xFu << 20;  // the FPU (CP10, CP11) on, before any floating-point instruction
  __asm__ volatile("dsb\n isb");
  __asm__ volatile("cpsid i");
  uint32_t* src = &__data_load;
  for (uint32_t* dst = &__data_start; dst < &__data_end;) *dst++ = *src++;
  for (uint32_t* dst = &__bss_start; dst < &__bss_end;) *dst++ = 0;
  for (void (**f)() = __init_array_start; f < __init_array_end; ++f) (*f)();
  main();
  for (;;) {
  }
}

void fault() {
  for (;;) {
  }
}

__attribute__((section(".vectors"), used)) void (*const vectors[16])() = {
    reinterpret_cast<void (*)()>(&__stack_top), reset, fault, fault, fault, fault, fault, nullptr,
    nullptr, nullptr, nullptr, fault, fault, nullptr, fault, fault};
}
