// Evidence over time: the checks of one car's drives combined, information-weighted, since the
// last step change. A knock moves the extrinsic at once; averaging across it would report a
// blend that is neither the old nor the new mount, so a record that disagrees with the running
// combination beyond both its noise and the tolerance starts a new segment, dated.
#pragma once

#include <string>
#include <vector>

#include "core/check.hpp"

namespace insalign {

struct HistoryConfig {
  /// A drive disagrees with the combination of the drives before it (since the last step) when a
  /// DOF differs by more than this many combined stddevs and by more than its tolerance.
  double step_sigmas = 4.0;
};

template <class V>
void visit_config(V& v, HistoryConfig& c) {
  v("step_sigmas", c.step_sigmas,
    "check --history: a drive differing from the drives before it by more than this many stddevs (and the tolerance) is a step change");
}

/// One checked drive as its check.json records it.
struct CheckRecord {
  std::string drive_end;               ///< ISO 8601 time of the drive's last sweep (sorts in time order)
  Iso3 T_ins_lidar_checked = Iso3::Identity();
  double time_offset_checked_s = 0.0;
  Iso3 T_ins_lidar_corrected = Iso3::Identity();  ///< what the drive measured
  double time_offset_corrected_s = 0.0;
  std::array<double, 7> stddev{};      ///< per DOF in its unit (m, deg, s); +inf: not determined
};

/// A step change found between two drives.
struct HistoryStep {
  std::string date;    ///< drive_end of the first drive after the change
  std::string before;  ///< drive_end of the last drive before it
  std::string why;     ///< which DOFs moved, by how much
};

struct HistoryFindings {
  std::array<DofCheck, 7> dofs;        ///< combined, relative to the installed extrinsic
  CheckVerdict verdict = CheckVerdict::kInconclusive;
  std::string message;
  int drives = 0;                      ///< records the verdict rests on (since the last step)
  std::string since;                   ///< drive_end of the first of them
  std::vector<HistoryStep> steps;      ///< every step change found, time order
};

/// Combines `records` (any order; sorted by drive_end) relative to the extrinsic installed now.
/// Needs at least one record.
HistoryFindings combine_history(std::vector<CheckRecord> records, const Iso3& T_ins_lidar_installed,
                                double time_offset_installed_s, const CheckConfig& check, const HistoryConfig& config);

}  // namespace insalign
