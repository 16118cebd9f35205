// What the fleet dashboard shows, computed from the history database: per car its latest
// verdict, whether it needs recalibration, its knocks (dated) and per-DOF changes over time.
#pragma once

#include <array>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "fleet/database.hpp"

namespace insalign::fleet {

/// Tolerances as `insalign check`'s defaults (CONVENTIONS.md): a change between two calibrations
/// is a knock when it is beyond the tolerance and beyond `knock_sigma` combined stddevs.
struct SummaryConfig {
  double tolerance_m = 0.02;
  double tolerance_deg = 0.05;
  double tolerance_time_s = 0.002;
  double knock_sigma = 3.0;
};

/// One run's value of one DOF: for a check its correction, for a calibration its change since
/// the car's first calibration (translation m, rotation deg as ZYX of R * R_first^T, time s).
struct DofPoint {
  std::string date, run_id, kind;
  double change = 0.0;
  std::optional<double> stddev;
  std::string verdict;  ///< checks: the DOF's verdict
};

struct Knock {
  std::string date;   ///< the first run that saw the change
  std::string after;  ///< the last run before it that did not (empty when none)
  std::string run_id;
  std::string what;   ///< "yaw +0.80 deg (check: drifted)"
};

struct CarSummary {
  std::string car;
  std::string state;  ///< recalibrate | changed | ok | inconclusive | calibrated | not-determined | failed
  bool needs_recalibration = false;
  std::string why;
  std::string latest_date, latest_run, latest_verdict, latest_report;
  std::vector<Knock> knocks;
  std::map<std::string, std::array<std::vector<DofPoint>, 7>> series;  ///< per LiDAR, per kFleetDofs
  int runs = 0, failed = 0;
};

struct FleetSummary {
  std::vector<CarSummary> cars;    ///< cars needing recalibration first, then by name
  std::vector<RunRecord> failed;   ///< rows that did not reach a verdict, with their errors
  std::vector<RunRecord> runs;     ///< every run, by car and date
};

FleetSummary summarize_fleet(const std::vector<RunRecord>& runs, const std::vector<ExtrinsicRecord>& extrinsics,
                             const SummaryConfig& config = {});

}  // namespace insalign::fleet
