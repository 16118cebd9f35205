// Checking an installed extrinsic (CONVENTIONS.md "Checking an installed extrinsic"): the
// correction a drive asks for, per degree of freedom and for the time offset, judged against
// tolerances with its stddev. Pure functions: the calibration that measures the correction is
// core/check_run.hpp, the files are the command line's.
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

/// The checked degrees of freedom: kDofNames' six, then the time offset.
inline constexpr std::array<const char*, 7> kCheckDofNames{"tx", "ty", "tz", "roll", "pitch", "yaw", "time_offset"};
inline constexpr std::array<const char*, 7> kCheckDofUnits{"m", "m", "m", "deg", "deg", "deg", "s"};
using Vec7 = Eigen::Matrix<double, 7, 1>;

struct CheckConfig {
  double tolerance_deg = 0.05;     ///< per rotation axis: a 0.05 deg error puts a point 100 m away 9 cm off
  double tolerance_m = 0.02;       ///< per translation axis
  double tolerance_time_s = 0.002; ///< time offset: 2 ms at 10 deg/s of yaw rate is 0.02 deg
  /// `ok` needs |correction| + ok_sigmas x stddev within the tolerance (CONVENTIONS: 2).
  double ok_sigmas = 2.0;
  /// `drifted` needs |correction| beyond the tolerance and beyond drift_sigmas x stddev (3).
  double drift_sigmas = 3.0;
  /// DOFs (comma separated names of kCheckDofNames) whose `not-observable` does not make the
  /// verdict inconclusive, e.g. "tz" for a fleet that never drives with fiducials or a known INS
  /// height. A drifted one still asks for recalibration. Empty: every DOF must be ok for `ok`.
  std::string unchecked_dofs;
  /// A correction beyond these is "grossly off": the message looks for the usual causes (an
  /// extrinsic in the opposite direction, another LiDAR's).
  double gross_rot_deg = 3.0;
  double gross_trans_m = 0.3;
};

template <class V>
void visit_config(V& v, CheckConfig& c) {
  v("tolerance_deg", c.tolerance_deg, "check: tolerance per rotation axis (roll, pitch, yaw), deg");
  v("tolerance_m", c.tolerance_m, "check: tolerance per translation axis (tx, ty, tz), m");
  v("tolerance_time_s", c.tolerance_time_s, "check: tolerance of the time offset, s");
  v("ok_sigmas", c.ok_sigmas, "check: a DOF is ok when |correction| + this x stddev is within the tolerance");
  v("drift_sigmas", c.drift_sigmas, "check: a DOF is drifted when |correction| exceeds the tolerance and this x stddev");
  v("unchecked_dofs", c.unchecked_dofs,
    "check: comma-separated DOFs whose not-observable does not make the verdict inconclusive (e.g. tz)");
  v("gross_rot_deg", c.gross_rot_deg, "check: a rotation correction beyond this is grossly off (wrong file?), deg");
  v("gross_trans_m", c.gross_trans_m, "check: a translation correction beyond this is grossly off (wrong file?), m");
}

enum class DofVerdictKind { kOk, kDrifted, kNotObservable };
inline constexpr std::array<std::pair<DofVerdictKind, std::string_view>, 3> kDofVerdictKindNames{
    {{DofVerdictKind::kOk, "ok"}, {DofVerdictKind::kDrifted, "drifted"}, {DofVerdictKind::kNotObservable, "not-observable"}}};
constexpr auto enum_names(DofVerdictKind) { return std::span(kDofVerdictKindNames); }

enum class CheckVerdict { kOk, kRecalibrate, kInconclusive };
inline constexpr std::array<std::pair<CheckVerdict, std::string_view>, 3> kCheckVerdictNames{
    {{CheckVerdict::kOk, "ok"}, {CheckVerdict::kRecalibrate, "recalibrate"}, {CheckVerdict::kInconclusive, "inconclusive"}}};
constexpr auto enum_names(CheckVerdict) { return std::span(kCheckVerdictNames); }

/// One DOF's finding, in its unit (m, deg, s).
struct DofCheck {
  double correction = 0.0;  ///< what the drive asks to add: estimate - installed
  double stddev = std::numeric_limits<double>::infinity();
  double tolerance = 0.0;
  DofVerdictKind verdict = DofVerdictKind::kNotObservable;
  std::string why;
};

/// What the drive says of the installed extrinsic, before any file is involved.
struct CheckFindings {
  std::array<DofCheck, 7> dofs;
  CheckVerdict verdict = CheckVerdict::kInconclusive;
  std::string message;  ///< one paragraph: the verdict and, for inconclusive, what drive would decide it
  std::vector<std::string> warnings;
};

/// The measured extrinsic a check compares with the installed one (from the calibration stages).
struct MeasuredExtrinsic {
  Iso3 T_ins_lidar = Iso3::Identity();
  double time_offset_s = 0.0;
  /// tx ty tz (m), roll pitch yaw (rad, about the INS axes), then the time offset (s); +inf: the
  /// drive does not determine it.
  Vec7 stddev = Vec7::Constant(std::numeric_limits<double>::infinity());
};

/// Per DOF, estimate - installed in the INS frame (CONVENTIONS' error definition with the estimate
/// for "est" and the installed extrinsic for "gt"): translation in m, the ZYX roll, pitch, yaw of
/// R_est * R_installed^T in deg, the time offset in s. Signed.
Vec7 extrinsic_correction(const Iso3& T_ins_lidar_installed, double time_offset_installed_s,
                          const Iso3& T_ins_lidar_est, double time_offset_est_s);

/// The tolerance of DOF `dof` (index into kCheckDofNames) in its unit.
double dof_tolerance(int dof, const CheckConfig& config);

/// The CONVENTIONS rule: drifted when |c| > tol and |c| > drift_sigmas sd; ok when |c| + ok_sigmas sd
/// <= tol; otherwise not-observable. `why` says which numbers decided it.
DofCheck judge_dof(int dof, double correction, double stddev, const CheckConfig& config);

/// What drive would decide DOF `dof` when this one could not ("yaw needs turns both ways").
std::string_view observing_drive(int dof);
/// A DOF's value as a person reads it: mm for translations, ms for the time offset, else deg.
std::string dof_amount(int dof, double v);

/// Which DOFs config.unchecked_dofs names. Throws std::invalid_argument on an unknown name.
std::array<bool, 7> unchecked_dofs(const CheckConfig& config);

/// Overall: recalibrate when any DOF drifted; ok when every DOF is ok (or unchecked); else
/// inconclusive.
CheckVerdict overall_verdict(const std::array<DofCheck, 7>& dofs, const std::array<bool, 7>& unchecked);

/// The whole judgement: corrections (extrinsic_correction), per-DOF verdicts, the overall
/// verdict and its message, and a warning when the installed extrinsic is grossly off (its
/// inverse much closer to the estimate: "given in the opposite direction").
CheckFindings judge_extrinsic(const Iso3& T_ins_lidar_installed, double time_offset_installed_s,
                              const MeasuredExtrinsic& measured, const CheckConfig& config);

/// The installed extrinsic with the corrections of `dofs` applied where the drive determined them
/// (finite stddev); the others keep their installed value. Rotations: R = Rz Ry Rx(c) R_installed.
struct CorrectedExtrinsic {
  Iso3 T_ins_lidar = Iso3::Identity();
  double time_offset_s = 0.0;
};
CorrectedExtrinsic corrected_extrinsic(const Iso3& T_ins_lidar_installed, double time_offset_installed_s,
                                       const std::array<DofCheck, 7>& dofs);

/// The verdict message for dofs already judged (used again when the history combines drives).
std::string verdict_message(const std::array<DofCheck, 7>& dofs, CheckVerdict verdict,
                            const std::array<bool, 7>& unchecked);

/// "this drive cannot decide yaw, time_offset. yaw needs turns both ways ... ." for the DOFs
/// `not-observable` and not unchecked: the inconclusive message's body.
std::string undecided_dofs_message(const std::array<DofCheck, 7>& dofs, const std::array<bool, 7>& unchecked);

}  // namespace insalign
