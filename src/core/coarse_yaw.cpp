#include "core/coarse_yaw.hpp"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>

#include "core/occupancy.hpp"
#include "core/voxel_grid.hpp"

namespace insalign {
namespace {

constexpr double kTwoPi = 6.283185307179586;

double rotation_angle(const Mat3& R) { return Eigen::AngleAxisd(R).angle(); }

}  // namespace

std::pair<std::size_t, std::size_t> straightest_stretch(const DriveFrames& frames, double stretch_m) {
  std::pair<std::size_t, std::size_t> best{0, frames.size() == 0 ? 0 : frames.size() - 1};
  if (frames.size() == 0 || frames.motion_m.back() <= stretch_m) return best;
  double best_turn = 1e9;
  for (std::size_t a = 0; a < frames.size(); a += 2) {
    std::size_t b = a;
    double turn = 0.0;
    while (b + 1 < frames.size() && frames.motion_m[b] - frames.motion_m[a] < stretch_m) {
      ++b;
      turn = std::max(turn, rotation_angle(frames.T_world_ins[a].linear().transpose() * frames.T_world_ins[b].linear()));
    }
    if (frames.motion_m[b] - frames.motion_m[a] < stretch_m) break;
    if (turn < best_turn) best_turn = turn, best = {a, b};
  }
  return best;
}

double coarse_yaw(const std::vector<const InitFrame*>& frames, const Levelling& level, double tz_insl_m,
                  double crispness_voxel_m, const CoarseYawConfig& config) {
  // Off-ground points in the levelled LiDAR frame (the ground is crisp under any yaw).
  std::vector<std::vector<Vec3>> p_lev(frames.size());
  for (std::size_t c = 0; c < frames.size(); ++c) {
    const InitFrame& f = *frames[c];
    for (std::size_t i = 0; i < f.sweep.size(); ++i)
      if (f.off_ground[i]) p_lev[c].push_back(level.R_lev_lidar * f.sweep.p_lidar[i].cast<double>());
    p_lev[c] = voxel_centroids(p_lev[c], config.voxel_m);
  }
  auto score = [&](double yaw_rad) {
    std::vector<Vec3> p_world;
    const Mat3 R_insl_lev = Eigen::AngleAxisd(yaw_rad, Vec3::UnitZ()).toRotationMatrix();
    for (std::size_t c = 0; c < frames.size(); ++c) {
      const Mat3 R_world_insl = frames[c]->T_world_ins.linear() * level.R_ins_insl;
      const Vec3 t_world_lidar = frames[c]->T_world_ins.translation() + R_world_insl * Vec3(0, 0, tz_insl_m);
      for (const Vec3& q : p_lev[c]) p_world.push_back(R_world_insl * (R_insl_lev * q) + t_world_lidar);
    }
    return occupancy_score(p_world, crispness_voxel_m);
  };
  const int n_yaw = std::max(4, static_cast<int>(std::lround(360.0 / config.yaw_step_deg)));
  std::vector<double> scores(static_cast<std::size_t>(n_yaw));
  tbb::parallel_for(0, n_yaw, [&](int k) { scores[static_cast<std::size_t>(k)] = score(kTwoPi * k / n_yaw); });
  const double yaw = kTwoPi * static_cast<double>(std::min_element(scores.begin(), scores.end()) - scores.begin()) / n_yaw;
  // Refined to about 1 deg around the best step.
  const double step = kTwoPi / n_yaw;
  const int n_fine = std::max(1, static_cast<int>(std::lround(step * kDegPerRad)));
  std::vector<double> fine(static_cast<std::size_t>(2 * n_fine + 1));
  tbb::parallel_for(0, 2 * n_fine + 1, [&](int k) {
    fine[static_cast<std::size_t>(k)] = score(yaw + (k - n_fine) * step / n_fine);
  });
  const int best = static_cast<int>(std::min_element(fine.begin(), fine.end()) - fine.begin());
  return std::remainder(yaw + (best - n_fine) * step / n_fine, kTwoPi);
}

}  // namespace insalign
