// spherestep_config.h: the coils the host's design drives, written by `spherestep export` (do not edit; re-export).
// design: prototype
// fingerprint: sha256:5deef638dfa597c5
// winding 82.96 ohm, 650.2 mH, 0.2893 A nominal on 24 V, 100 W supply
#pragma once
#include "drive.h"

namespace spherestep_config {
const uint8_t COILS = 29;
// max current A, max duty, supply power W, continuous current A, thermal time s, resistance ohm, trip ratio
const spherestep::Limits LIMITS = {0.2893035498173244, 0.95, 100.0, 0.2893035498173244, 60.0, 82.95784830554058, 1.25};
const double SUPPLY_V = 24.0;
const double INDUCTANCE_H = 0.6502262670441696;
const int32_t NOMINAL_MA = 289;
}  // namespace spherestep_config
