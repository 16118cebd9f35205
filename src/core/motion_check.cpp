#include "core/motion_check.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <fmt/format.h>

namespace insalign {
namespace {


/// "0.4 mm", "37 cm", "120 m": a distance a person reads at a glance.
std::string distance_words(double d_m) {
  if (d_m < 0.01) return fmt::format("{:.1f} mm", d_m * 1e3);
  if (d_m < 1.0) return fmt::format("{:.0f} cm", d_m * 1e2);
  return fmt::format("{:.0f} m", d_m);
}

std::string duration_words(double t_s) { return t_s < 10.0 ? fmt::format("{:.1f} s", t_s) : fmt::format("{:.0f} s", t_s); }

double heading_rad(const Iso3& T_world_ins) {
  // Rotation about the world vertical (ZYX yaw); the same for any choice of the INS forward axis
  // up to a constant, and only differences are used.
  return std::atan2(T_world_ins.linear()(1, 0), T_world_ins.linear()(0, 0));
}

constexpr const char* kAdvice =
    "Record a drive of one to two minutes with figure-8s (turns both ways, at least 10 m and "
    "90 deg of turning) in a place with walls, poles or buildings around.";

}  // namespace

namespace {

// Path length, turning and speed on a grid of speed_window_s over [t0, t1]: INS position and
// heading noise between closely spaced poses would otherwise add up to metres and degrees on a
// standstill.
void measure_path(const PoseStream& poses, double t0, double t1, double window_s, MotionCheck& out) {
  const std::size_t n_steps = std::max<std::size_t>(1, static_cast<std::size_t>(std::ceil((t1 - t0) / window_s)));
  Iso3 T_prev = poses.T_world_ins(t0);
  double heading = 0.0, heading_min = 0.0, heading_max = 0.0, t_prev = t0;
  for (std::size_t k = 1; k <= n_steps; ++k) {
    const double t = (k == n_steps) ? t1 : t0 + double(k) * (t1 - t0) / double(n_steps);
    const Iso3 T = poses.T_world_ins(t);
    const double d = (T.translation() - T_prev.translation()).norm();
    out.distance_m += d;
    if (t - t_prev > 0) out.max_speed_mps = std::max(out.max_speed_mps, d / (t - t_prev));
    const double dpsi = wrap_pi(heading_rad(T) - heading_rad(T_prev));
    heading += dpsi;
    out.heading_change_deg += std::abs(dpsi) * kDegPerRad;
    heading_min = std::min(heading_min, heading), heading_max = std::max(heading_max, heading);
    T_prev = T, t_prev = t;
  }
  out.heading_spread_deg = (heading_max - heading_min) * kDegPerRad;
}

// Lever-arm sensitivity over the frames (each frame weighs the same in the map): the map
// disagreement of a lever-arm error d is (R_k - R_mean) d, whose mean square over the frames is
// d^T (I - R_mean^T R_mean) d. Its smallest eigenvalue belongs to the vertical (never seen by
// planar driving, stage 3); the next one is the worst horizontal direction.
double lever_arm_sensitivity(const PoseStream& poses, const std::vector<FrameInfo>& frames) {
  Mat3 R_mean = Mat3::Zero();
  std::size_t n = 0;
  for (const FrameInfo& f : frames) {
    if (!poses.covers(f.t_end_s)) continue;
    R_mean += poses.T_world_ins(f.t_end_s).linear();
    ++n;
  }
  if (n == 0) return 0.0;
  R_mean /= double(n);
  const Mat3 info = Mat3::Identity() - R_mean.transpose() * R_mean;
  const Eigen::SelfAdjointEigenSolver<Mat3> eig(0.5 * (info + info.transpose()));
  return std::sqrt(std::max(eig.eigenvalues()(1), 0.0));
}

std::string explain(const MotionCheck& out, const MotionCheckConfig& config, bool moved, bool turned_enough) {
  const std::string drive = distance_words(out.distance_m) + " over the " + duration_words(out.duration_s) + " of " +
                            std::to_string(out.frames) + (out.frames == 1 ? " frame" : " frames");
  if (!moved) {
    return "the vehicle moved only " + drive + " (need at least " + distance_words(config.min_distance_m) +
           "): it is practically standing still, so no part of the extrinsic is determined. A rotation error "
           "shows only as a disagreement between views from places some metres apart, and the lever arm only "
           "between views at different headings. " + std::string(kAdvice);
  }
  if (!turned_enough) {
    return fmt::format(
               "the vehicle drove {} but turned only {:.0f} deg in total (heading spread {:.0f} deg, lever-arm "
               "sensitivity {:.2f}, need {:.0f} deg and {:.2f}). ",
               drive, out.heading_change_deg, out.heading_spread_deg, out.lever_arm_sensitivity,
               config.min_heading_change_deg, config.min_lever_arm_sensitivity) +
           "With an almost constant heading the lever arm x, y is not determined (a lever-arm error moves every "
           "point of the map alike, so the map stays sharp), nor the roll about the direction of travel; the "
           "time offset trades against the lever arm along the direction of travel. Only pitch and yaw are seen, "
           "through the distance driven. " + std::string(kAdvice);
  }
  return fmt::format("the drive determines roll, pitch, yaw and the lever arm x, y: {}, {:.0f} deg of turning, "
                     "heading spread {:.0f} deg, lever-arm sensitivity {:.2f}. tz needs fiducials or "
                     "--ins-height-m: planar driving never shows it.",
                     drive, out.heading_change_deg, out.heading_spread_deg, out.lever_arm_sensitivity);
}

}  // namespace

MotionCheck check_motion(const PoseStream& poses, const std::vector<FrameInfo>& frames,
                         const MotionCheckConfig& config) {
  MotionCheck out;
  out.frames = frames.size();
  if (frames.empty() || poses.empty()) {
    out.explanation = frames.empty() ? "no LiDAR frames: nothing can be calibrated" : "no poses: nothing can be calibrated";
    return out;
  }
  // Only the frames' span counts: poses outside it never reach the calibration.
  double t0 = frames.front().t_end_s, t1 = frames.front().t_end_s;
  for (const FrameInfo& f : frames) t0 = std::min(t0, f.t_end_s), t1 = std::max(t1, f.t_end_s);
  t0 = std::max(t0, poses.t_begin());
  t1 = std::min(t1, poses.t_end());
  if (!(t1 >= t0)) {
    out.explanation = "the poses do not cover the frames' times: nothing can be calibrated";
    return out;
  }
  out.duration_s = t1 - t0;
  measure_path(poses, t0, t1, std::max(config.speed_window_s, 1e-3), out);
  out.lever_arm_sensitivity = lever_arm_sensitivity(poses, frames);
  const bool moved = out.distance_m >= config.min_distance_m;
  const bool turned = out.heading_change_deg >= config.min_heading_change_deg;
  const bool spread = out.lever_arm_sensitivity >= config.min_lever_arm_sensitivity;
  out.rotation_determined = moved && turned;
  out.lever_arm_xy_determined = moved && turned && spread;
  out.ok = out.rotation_determined && out.lever_arm_xy_determined;
  out.explanation = explain(out, config, moved, turned && spread);
  return out;
}

}  // namespace insalign
