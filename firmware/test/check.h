// The firmware tests' one harness: check(ok, what) counts, prints "FAIL what" on a failure, and report() prints the
// closing "N passed, N failed" and returns the exit status (0 only if nothing failed).
#pragma once

#include <cstdio>
#include <string>

namespace check_harness {

static int passed = 0;
static int failed = 0;

}  // namespace check_harness

static inline void check(bool ok, const std::string& what) {
  if (ok) {
    ++check_harness::passed;
  } else {
    ++check_harness::failed;
    std::printf("FAIL %s\n", what.c_str());
  }
}

static inline int report() {
  std::printf("%d passed, %d failed\n", check_harness::passed, check_harness::failed);
  return check_harness::failed == 0 ? 0 : 1;
}
