// The one place a degree of freedom's final status is decided: whether it is `determined`, its
// reported stddev, where tz came from, and the sentences that tell the user about it. Every
// stage reports its own verdicts (StageOutcome); this turns the evidence of all of them into the
// result, so that `determined`, `stddev` and the warnings cannot contradict each other:
//   determined[i]  <=>  stddev[i] finite  <=>  no "not determined" sentence names DOF i.
#pragma once

#include <array>
#include <limits>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "core/enum_names.hpp"
#include "core/geometry.hpp"

namespace insalign {

/// Where the final tz came from (named in the result as `tz_source` and in its sentence).
enum class TzSource {
  kFiducials,   ///< stage 3: surveyed fiducials (absolute)
  kInsHeight,   ///< stage 3: the ground under the INS and --ins-height-m
  kData,        ///< stage 1: the drive's roll and pitch excite tz (no absolute reference)
  kInit,        ///< the --init file's tz, kept (nothing in the drive fixes it)
  kInsHeightGiven,  ///< --ins-height-m as the start's INS height (stage 3 could not measure the ground)
  kGuess,       ///< the built-in INS height guess (init.ins_height_guess_m): no init, no fiducials
};
inline constexpr std::array<std::pair<TzSource, std::string_view>, 6> kTzSourceNames{
    {{TzSource::kFiducials, "fiducials"},
     {TzSource::kInsHeight, "ins-height"},
     {TzSource::kData, "data"},
     {TzSource::kInit, "init"},
     {TzSource::kInsHeightGiven, "ins-height-given"},
     {TzSource::kGuess, "guess"}}};
constexpr auto enum_names(TzSource) { return std::span(kTzSourceNames); }
/// The source as a person reads it ("the --init file", "the built-in guess (INS 1.00 m above the ground)").
std::string tz_source_phrase(TzSource source);

struct DofStatusConfig {
  /// tz from the drive alone (stage 1, no fiducials or height): determined only when its stated
  /// stddev (the formal one widened as the segments widen the others, at least the INS's height
  /// error) is below this; else reported not determined, with the value and where it came from.
  double max_data_tz_stddev_m = 0.02;
  /// A determined DOF whose stddev is above these is called weak in the summary's first lines.
  double weak_trans_m = 0.01;
  double weak_rot_deg = 0.05;
};

template <class V>
void visit_config(V& v, DofStatusConfig& c) {
  v("max_data_tz_stddev_m", c.max_data_tz_stddev_m,
    "tz from the drive alone (no fiducials or height) counts as determined only with a stddev below this, m");
  v("weak_trans_m", c.weak_trans_m, "a determined translation with a larger stddev is reported as weak, m");
  v("weak_rot_deg", c.weak_rot_deg, "a determined rotation with a larger stddev is reported as weak, deg");
}

/// What the stages found, per DOF [tx ty tz roll pitch yaw].
struct DofEvidence {
  std::array<bool, 6> observed{};  ///< a stage determined it (tz: stage 3, or stage 1's tz estimate)
  /// The stated stddev (m, rad) per DOF as the pipeline widened it (segments, INS errors, tz's
  /// coupling into x and y); +inf where no stage gave one.
  Vec6 stddev = Vec6::Constant(std::numeric_limits<double>::infinity());
  TzSource tz_source = TzSource::kGuess;
  double tz_m = 0.0;                 ///< the final tz
  double tz_assumed_sigma_m = 0.0;   ///< not determined: the uncertainty carried into x and y (0: none carried)
  double dx_per_tz = 0.0, dy_per_tz = 0.0;  ///< stage 2's x, y change per metre of tz (m/m)
  /// The share of each stddev that the INS's slow error, measured by the trajectory correction,
  /// leaves in the estimate (m, rad; 0: none measured).
  Vec6 ins_drift_stddev = Vec6::Zero();
};

/// One DOF's final status.
struct DofStatus {
  bool determined = false;
  double stddev = std::numeric_limits<double>::infinity();  ///< m or rad; +inf when not determined
  bool weak = false;                                        ///< determined, stddev above the weak limits
};

struct DofStatusResult {
  std::array<DofStatus, 6> dofs;
  TzSource tz_source = TzSource::kGuess;
  /// Short sentences, each with what to do, for the first lines of the summary and the report:
  /// a DOF not determined or weak (tz: where its value came from).
  std::vector<std::string> advice;
  std::array<bool, 6> determined() const;
  Vec6 stddev() const;
};

DofStatusResult decide_dof_status(const DofEvidence& evidence, const DofStatusConfig& config = {});

}  // namespace insalign
