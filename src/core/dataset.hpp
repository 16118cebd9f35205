// What a calibration run works on: the INS trajectory, the LiDAR frames (loaded on demand so a
// long drive never sits in memory at once), optional fiducials and an optional initial guess.
#pragma once

#include <functional>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/pose_stream.hpp"
#include "core/sweep.hpp"

namespace insalign {

struct FrameInfo {
  std::string name;
  double t_end_s = 0.0;  ///< frame time (end of sweep), LiDAR clock, absolute seconds
};

/// Frames in time order plus a thread-safe loader. Stages pick the frames they need by index.
struct FrameSource {
  std::vector<FrameInfo> frames;
  std::function<Sweep(std::size_t index)> load;
};

/// A surveyed point in the (recentred) world frame of the pose file.
struct Fiducial {
  std::string id;
  Vec3 p_world = Vec3::Zero();
};

/// What the INS says of its own solution at a time; a source that says nothing gives kUnknown.
enum class GnssSolution {
  kUnknown,       ///< the source does not say
  kRtkFixed,      ///< carrier-phase ambiguities fixed (cm level)
  kRtkFloat,      ///< carrier phase, ambiguities float (dm level)
  kDifferential,  ///< code differential, SBAS, PPP converging (dm to m)
  kSingle,        ///< single point (m level)
  kInsOnly,       ///< no GNSS: the INS is coasting on its inertial sensors
  kInvalid,       ///< the source marks the solution unusable
};

struct InsQuality {
  double t_s = 0.0;  ///< INS clock, as the poses
  GnssSolution solution = GnssSolution::kUnknown;
  /// One-sigma horizontal and vertical position error the INS states (m); NaN: not stated.
  double horizontal_stddev_m = std::numeric_limits<double>::quiet_NaN();
  double vertical_stddev_m = std::numeric_limits<double>::quiet_NaN();
};

struct Dataset {
  FrameSource frames;
  PoseStream poses;                      ///< T_world_ins, world recentred on world_origin_m
  std::vector<InsQuality> ins_quality;   ///< time order; empty when the source states nothing
  Vec3 world_origin_m = Vec3::Zero();    ///< subtracted from pose file positions (UTM is large)
  std::vector<Fiducial> fiducials;       ///< same recentred world frame
  std::optional<Iso3> T_ins_lidar_init;  ///< from --init, if given
  /// The time offset the stages start from (t_ins = t_lidar + offset): the installed one a check
  /// is given; unset, 0 (the data's coarse search still moves the start where it clearly differs).
  std::optional<double> time_offset_init_s;
};

/// An in-memory FrameSource over sweeps already loaded (simulation, tests).
inline FrameSource frame_source_from(std::vector<Sweep> sweeps) {
  FrameSource source;
  for (const Sweep& s : sweeps) source.frames.push_back({s.name, s.t_end_s});
  auto shared = std::make_shared<const std::vector<Sweep>>(std::move(sweeps));
  source.load = [shared](std::size_t i) { return shared->at(i); };
  return source;
}

}  // namespace insalign
