// Vehicle motion for the simulator: where the vehicle (x forward, y left, z up, origin at the INS)
// is at each instant, with the roll and pitch a real car shows on turns, accelerations and slopes.
#pragma once

#include <vector>

#include "core/geometry.hpp"
#include "core/pose_stream.hpp"
#include "sim/drive_plan.hpp"
#include "sim/random.hpp"
#include "sim/scene.hpp"
#include "sim/simulate.hpp"

namespace insalign::sim {

class Trajectory {
 public:
  /// Throws std::invalid_argument if the config cannot make a trajectory (e.g. no recorded poses).
  Trajectory(const SimConfig& config, Rng& rng);

  /// Vehicle pose at tau_s seconds after the start of the motion; clamped outside [0, duration].
  Iso3 T_world_vehicle(double tau_s) const;
  double duration_s() const { return duration_s_; }
  const GroundPlane& ground() const { return ground_; }
  double ins_height_m() const { return ins_height_m_; }
  /// One pass of the driven path (world xy, dense): what the scene keeps clear.
  const std::vector<Vec2>& loop_xy() const { return loop_xy_; }
  /// Whether this is an ordinary drive (sim/drive_plan.hpp): its scene is scaled to its length.
  bool ordinary() const { return !profile_.t_s.empty(); }

 private:
  struct PathSample {
    double x, y, heading_rad, curvature_per_m;
  };
  void init_recorded(const std::vector<StampedPose>& in);
  void init_analytic(const SimConfig& config, Rng& rng, double yaw0);
  void init_ordinary(const SimConfig& config, Rng& rng, double yaw0);
  PathSample path_at(double s_m) const;
  void speed_at(double tau_s, double& s_m, double& v_mps, double& a_mps2) const;

  TrajectoryKind kind_;
  GroundPlane ground_;
  double ins_height_m_ = 0.8;
  double duration_s_ = 0.0;
  std::vector<Vec2> loop_xy_;
  // Analytic paths: samples every kPathStepM metres of one loop, repeated loops_ times.
  std::vector<PathSample> table_;
  double loop_length_m_ = 0.0;
  double total_length_m_ = 0.0;
  double cruise_mps_ = 0.0, ramp_s_ = 3.0;
  bool closed_ = false;              ///< the table is one loop of a closed path
  SpeedProfile profile_;             ///< ordinary drives: speed with stops (empty: the ramps above)
  // Recorded: the vehicle poses, re-timed to start at 0.
  PoseStream recorded_;
};

/// Rotation of the INS body axes in the vehicle frame (T_vehicle_ins, no translation).
Iso3 vehicle_from_ins(InsAxes axes);

}  // namespace insalign::sim
