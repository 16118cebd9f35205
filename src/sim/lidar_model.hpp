// The simulated LiDAR sensors: spinning multi-beam models (a table of beam elevations) and a
// solid-state Livox-like model whose beams trace a non-repetitive rosette.
#pragma once

#include <string>
#include <vector>

#include "core/geometry.hpp"

namespace insalign::sim {

enum class ScanPattern {
  kSpinning,  ///< one column of beams per azimuth step, clockwise, one revolution per frame
  kRosette,   ///< Risley-prism rosette (Livox): never repeats, fills its field of view over time
};

struct LidarModel {
  std::string name;
  ScanPattern pattern = ScanPattern::kSpinning;
  std::vector<double> elevation_deg;  ///< spinning: per ring (ring r = index r)
  // Rosette (Livox Avia: 70.4 deg circular field of view in its non-repetitive mode, 240 000
  // points/s over 6 laser lines, 10 Hz frames; Livox Avia user manual, specifications).
  double fov_deg = 0.0;          ///< full cone angle about the sensor's +x axis
  double point_rate_hz = 0.0;    ///< points per second over all lines, at the default resolution
  int lines = 0;                 ///< lasers firing together (ring = line)
  double prism_hz[2] = {0, 0};   ///< rotation rates of the two prisms (opposite senses)
};

/// Throws std::invalid_argument for an unknown name.
LidarModel lidar_model(const std::string& name);
std::vector<std::string> lidar_model_names();

/// Rosette: the unit direction (LiDAR frame) of `line` at pattern time tau_s (seconds since the
/// sensor started; continuous across frames, so successive frames fill different gaps).
Vec3 rosette_direction(const LidarModel& model, int line, double tau_s);

}  // namespace insalign::sim
