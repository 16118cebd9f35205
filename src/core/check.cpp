#include "core/check.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

namespace insalign {
namespace {

bool is_rotation(int dof) { return dof >= 3 && dof <= 5; }

double rotation_angle_deg(const Mat3& R) {
  return Eigen::AngleAxisd(R).angle() * kDegPerRad;
}

// The usual causes of a grossly wrong extrinsic, judged from the estimate: the installed one
// given in the opposite direction (T_lidar_ins for T_ins_lidar), or not this LiDAR's.
// tz_known: without it the estimate's tz is only the starting value (the installed file's), no evidence.
std::string gross_warning(const Iso3& T_installed, const Iso3& T_est, bool tz_known, const CheckConfig& config) {
  const double rot_deg = rotation_angle_deg(T_est.linear() * T_installed.linear().transpose());
  const double trans_m = (T_est.translation() - T_installed.translation()).norm();
  if (rot_deg <= config.gross_rot_deg && trans_m <= config.gross_trans_m) return "";
  const Iso3 T_inverted = T_installed.inverse();
  const double inv_rot_deg = rotation_angle_deg(T_est.linear() * T_inverted.linear().transpose());
  Vec3 inv_dt = T_est.translation() - T_inverted.translation();
  if (!tz_known) inv_dt.z() = 0.0;
  const double inv_trans_m = inv_dt.norm();
  std::string out = fmt::format("the installed extrinsic is grossly off ({:.2f} deg, {:.3f} m from what the drive shows)",
                                rot_deg, trans_m);
  if (inv_rot_deg <= config.gross_rot_deg && inv_trans_m <= config.gross_trans_m)
    return out + fmt::format(": its inverse is within {:.2f} deg and {:.3f} m of it, so the file most likely holds "
                             "T_lidar_ins where T_ins_lidar was expected (or the reverse): invert it",
                             inv_rot_deg, inv_trans_m);
  return out + ": is it this LiDAR's extrinsic (not another LiDAR's of the rig), in the direction T_ins_lidar?";
}

}  // namespace

std::string dof_amount(int dof, double v) {
  if (dof <= 2) return fmt::format("{:.1f} mm", 1e3 * v);
  if (dof == 6) return fmt::format("{:.2f} ms", 1e3 * v);
  return fmt::format("{:.3f} deg", v);
}

Vec7 extrinsic_correction(const Iso3& T_installed, double offset_installed_s, const Iso3& T_est, double offset_est_s) {
  Vec7 c;
  c.head<3>() = T_est.translation() - T_installed.translation();
  c.segment<3>(3) = rpy_from_rotation(T_est.linear() * T_installed.linear().transpose()) * kDegPerRad;
  c(6) = offset_est_s - offset_installed_s;
  return c;
}

double dof_tolerance(int dof, const CheckConfig& config) {
  if (dof <= 2) return config.tolerance_m;
  if (dof == 6) return config.tolerance_time_s;
  return config.tolerance_deg;
}

DofCheck judge_dof(int dof, double correction, double stddev, const CheckConfig& config) {
  DofCheck d;
  d.correction = correction;
  d.stddev = stddev;
  d.tolerance = dof_tolerance(dof, config);
  const double c = std::abs(correction);
  const bool finite = std::isfinite(stddev) && std::isfinite(correction);
  if (finite && c > d.tolerance && c > config.drift_sigmas * stddev) {
    d.verdict = DofVerdictKind::kDrifted;
    d.why = fmt::format("the correction {} is beyond the tolerance {} and {:.1f} stddev ({})", dof_amount(dof, correction),
                        dof_amount(dof, d.tolerance), c / std::max(stddev, 1e-300), dof_amount(dof, stddev));
  } else if (finite && c + config.ok_sigmas * stddev <= d.tolerance) {
    d.verdict = DofVerdictKind::kOk;
    d.why = fmt::format("the correction {} +- {:g} stddev ({}) lies within the tolerance {}", dof_amount(dof, correction),
                        config.ok_sigmas, dof_amount(dof, stddev), dof_amount(dof, d.tolerance));
  } else {
    d.verdict = DofVerdictKind::kNotObservable;
    d.why = finite ? fmt::format("the correction {} with stddev {} neither clears the tolerance {} by {:g} stddev nor "
                                 "exceeds it by {:g} stddev: {}",
                                 dof_amount(dof, correction), dof_amount(dof, stddev), dof_amount(dof, d.tolerance),
                                 config.ok_sigmas, config.drift_sigmas, observing_drive(dof))
                   : fmt::format("this drive does not determine it: {}", observing_drive(dof));
  }
  return d;
}

std::string_view observing_drive(int dof) {
  switch (dof) {
    case 0:
    case 1: return "the horizontal lever arm needs turns (90 deg or more, left and right) with walls or poles in view";
    case 2: return "tz needs fiducials (--fiducials) or a height reference (--ins-height-m)";
    case 3: return "roll needs turns with structure beside the road (a straight drive is blind to it)";
    case 4: return "pitch needs driving past walls and poles, with accelerations, braking or slopes";
    case 5: return "yaw needs turns both ways with walls or poles in view";
    default: return "the time offset needs turns at speed (a fast heading change shows a lag as a smear)";
  }
}

std::array<bool, 7> unchecked_dofs(const CheckConfig& config) {
  std::array<bool, 7> out{};
  std::stringstream list(config.unchecked_dofs);
  std::string name;
  while (std::getline(list, name, ',')) {
    name.erase(0, name.find_first_not_of(" \t"));
    name.erase(name.find_last_not_of(" \t") + 1);
    if (name.empty()) continue;
    bool found = false;
    for (int i = 0; i < 7; ++i) {
      if (name == kCheckDofNames[i]) out[i] = found = true;
    }
    if (!found)
      throw std::invalid_argument("check.unchecked_dofs: unknown DOF \"" + name +
                                  "\" (tx, ty, tz, roll, pitch, yaw, time_offset)");
  }
  return out;
}

CheckVerdict overall_verdict(const std::array<DofCheck, 7>& dofs, const std::array<bool, 7>& unchecked) {
  bool all_ok = true;
  for (int i = 0; i < 7; ++i) {
    if (dofs[i].verdict == DofVerdictKind::kDrifted) return CheckVerdict::kRecalibrate;
    if (dofs[i].verdict != DofVerdictKind::kOk && !unchecked[i]) all_ok = false;
  }
  return all_ok ? CheckVerdict::kOk : CheckVerdict::kInconclusive;
}

std::string verdict_message(const std::array<DofCheck, 7>& dofs, CheckVerdict verdict,
                            const std::array<bool, 7>& unchecked) {
  std::vector<std::string> names;
  auto list = [&](DofVerdictKind kind, bool include_unchecked) {
    names.clear();
    for (int i = 0; i < 7; ++i)
      if (dofs[i].verdict == kind && (include_unchecked || !unchecked[i])) names.push_back(kCheckDofNames[i]);
    return fmt::format("{}", fmt::join(names, ", "));
  };
  if (verdict == CheckVerdict::kRecalibrate) {
    std::string out = "recalibrate: drifted " + list(DofVerdictKind::kDrifted, true) + " (";
    bool first = true;
    for (int i = 0; i < 7; ++i) {
      if (dofs[i].verdict != DofVerdictKind::kDrifted) continue;
      out += fmt::format("{}{} {}", first ? "" : ", ", kCheckDofNames[i], dof_amount(i, dofs[i].correction));
      first = false;
    }
    return out + "); the corrected extrinsic is in corrected/";
  }
  if (verdict == CheckVerdict::kOk) {
    std::string out = "ok: every checked DOF is within its tolerance";
    const std::string skipped = list(DofVerdictKind::kNotObservable, true);
    if (!skipped.empty()) out += " (not checked, as check.unchecked_dofs allows: " + skipped + ")";
    return out;
  }
  return "inconclusive: " + undecided_dofs_message(dofs, unchecked);
}

std::string undecided_dofs_message(const std::array<DofCheck, 7>& dofs, const std::array<bool, 7>& unchecked) {
  std::vector<std::string> names, drives;
  for (int i = 0; i < 7; ++i) {
    if (dofs[i].verdict != DofVerdictKind::kNotObservable || unchecked[i]) continue;
    names.push_back(kCheckDofNames[i]);
    const std::string drive(observing_drive(i));  // tx and ty share theirs: said once
    if (std::find(drives.begin(), drives.end(), drive) == drives.end()) drives.push_back(drive);
  }
  std::string out = fmt::format("this drive cannot decide {}.", fmt::join(names, ", "));
  for (std::string d : drives) {
    if (d.starts_with("the ")) d[0] = 'T';  // a sentence of its own ("tz needs ..." keeps the DOF's name)
    out += " " + d + ".";
  }
  return out;
}

CorrectedExtrinsic corrected_extrinsic(const Iso3& T_installed, double offset_installed_s,
                                       const std::array<DofCheck, 7>& dofs) {
  Vec7 c = Vec7::Zero();
  for (int i = 0; i < 7; ++i)
    if (std::isfinite(dofs[i].stddev) && std::isfinite(dofs[i].correction)) c(i) = dofs[i].correction;
  CorrectedExtrinsic out;
  out.T_ins_lidar = T_installed;
  out.T_ins_lidar.linear() = rotation_from_rpy(c.segment<3>(3) * kRadPerDeg) * T_installed.linear();
  out.T_ins_lidar.translation() = T_installed.translation() + c.head<3>();
  out.time_offset_s = offset_installed_s + c(6);
  return out;
}

CheckFindings judge_extrinsic(const Iso3& T_installed, double offset_installed_s, const MeasuredExtrinsic& measured,
                              const CheckConfig& config) {
  CheckFindings f;
  const Vec7 c = extrinsic_correction(T_installed, offset_installed_s, measured.T_ins_lidar, measured.time_offset_s);
  for (int i = 0; i < 7; ++i) {
    const double sd = is_rotation(i) ? measured.stddev(i) * kDegPerRad : measured.stddev(i);
    f.dofs[i] = judge_dof(i, c(i), sd, config);
  }
  const std::array<bool, 7> unchecked = unchecked_dofs(config);
  f.verdict = overall_verdict(f.dofs, unchecked);
  f.message = verdict_message(f.dofs, f.verdict, unchecked);
  const std::string gross = gross_warning(T_installed, measured.T_ins_lidar, std::isfinite(measured.stddev(2)), config);
  if (!gross.empty()) {
    f.warnings.push_back(gross);
    f.message += " (" + gross + ")";
  }
  return f;
}

}  // namespace insalign
