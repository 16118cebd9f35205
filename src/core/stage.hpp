// What every stage returns beside its own estimate: one status, one verdict per degree of
// freedom, one uncertainty convention. A stage never throws for a drive that is merely
// degenerate (too little motion, no ground, no fiducials): it says so here, and the pipeline
// decides whether that stops the calibration.
#pragma once

#include <array>
#include <limits>
#include <string>

#include "core/enum_names.hpp"
#include "core/geometry.hpp"

namespace insalign {

enum class StageStatus {
  kOk,            ///< ran; its estimate stands
  kUndetermined,  ///< ran, but the drive cannot determine what it estimates (message says why)
  kSkipped,       ///< not run: disabled, or nothing to work with (message says which)
};
inline constexpr std::array<std::pair<StageStatus, std::string_view>, 3> kStageStatusNames{{
    {StageStatus::kOk, "ok"}, {StageStatus::kUndetermined, "undetermined"}, {StageStatus::kSkipped, "skipped"}}};
constexpr auto enum_names(StageStatus) { return std::span(kStageStatusNames); }

/// Degrees of freedom in this order everywhere: tx ty tz (m), roll pitch yaw (rad, about the
/// INS axes: R' = exp(w) R, so yaw is about the INS vertical).
inline constexpr std::array<const char*, 6> kDofNames{"tx", "ty", "tz", "roll", "pitch", "yaw"};

struct StageOutcome {
  StageStatus status = StageStatus::kSkipped;
  std::string message;                  ///< plain words; empty when kOk with nothing to add
  std::array<bool, 6> determined{};     ///< which DOFs this stage determined
  /// One sigma, m and rad. Not determined: +infinity (and determined[i] false).
  Vec6 stddev = Vec6::Constant(std::numeric_limits<double>::infinity());
  double wall_time_s = 0.0;
  bool ok() const { return status == StageStatus::kOk; }
};

}  // namespace insalign
