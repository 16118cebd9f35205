#include "sim/lidar_model.hpp"

#include <cmath>
#include <numbers>
#include <stdexcept>

namespace insalign::sim {
namespace {

constexpr double kPi = std::numbers::pi;
// The six Avia lines sit on a small hexagon around the pattern; the pattern's radius leaves room
// for them inside the field of view.
constexpr double kLineSpreadDeg = 1.2;

}  // namespace

LidarModel lidar_model(const std::string& name) {
  LidarModel m;
  m.name = name;
  if (name == "pandar64") {
    // Sparse at the top and bottom, a dense band (1/6 deg) around the horizon.
    for (double e : {15.0, 11.0, 8.0, 5.0, 3.0}) m.elevation_deg.push_back(e);
    for (int i = 0; i <= 48; ++i) m.elevation_deg.push_back(2.0 - i / 6.0);
    for (double e : {-7.0, -8.0, -9.0, -10.0, -11.0, -12.0, -13.0, -14.0, -19.0, -25.0}) m.elevation_deg.push_back(e);
  } else if (name == "hdl32") {
    for (int i = 0; i < 32; ++i) m.elevation_deg.push_back(10.67 - i * (41.34 / 31.0));
  } else if (name == "os1-64") {
    for (int i = 0; i < 64; ++i) m.elevation_deg.push_back(16.6 - i * (33.2 / 63.0));
  } else if (name == "vlp16") {
    // 16 rings 2 deg apart: few rings on the ground and on each wall, the sparsest common sensor.
    for (int i = 0; i < 16; ++i) m.elevation_deg.push_back(15.0 - 2.0 * i);
  } else if (name == "livox-avia") {
    m.pattern = ScanPattern::kRosette;
    m.fov_deg = 70.4;
    m.point_rate_hz = 240000.0;
    m.lines = 6;
    // Opposite prisms at nearby, incommensurate rates: about 12 passes through the centre per
    // 0.1 s frame while the pattern turns by half a revolution, so one frame covers part of the
    // field of view and the next ones fill the gaps (tests/sim_rig_test.cpp measures it).
    m.prism_hz[0] = 65.1537;
    m.prism_hz[1] = -54.8411;
  } else {
    std::string names;
    for (const std::string& n : lidar_model_names()) {
      if (!names.empty()) names += ", ";
      names += n;
    }
    throw std::invalid_argument("unknown LiDAR model '" + name + "' (" + names + ")");
  }
  return m;
}

std::vector<std::string> lidar_model_names() { return {"pandar64", "hdl32", "os1-64", "vlp16", "livox-avia"}; }

Vec3 rosette_direction(const LidarModel& m, int line, double tau_s) {
  // Two prisms of equal deflection a: the sum of two counter-rotating vectors, a rose through the
  // centre whose petals precess (Risley prism pair).
  const double a = 0.5 * (0.5 * m.fov_deg - kLineSpreadDeg) * kRadPerDeg;
  const double p1 = 2 * kPi * m.prism_hz[0] * tau_s, p2 = 2 * kPi * m.prism_hz[1] * tau_s;
  const double line_angle = 2 * kPi * line / std::max(1, m.lines);
  const double spread = kLineSpreadDeg * kRadPerDeg;
  const double u = a * (std::cos(p1) + std::cos(p2)) + spread * std::cos(line_angle);
  const double v = a * (std::sin(p1) + std::sin(p2)) + spread * std::sin(line_angle);
  const double r = std::hypot(u, v);  // angle from the boresight (+x)
  if (r < 1e-12) return Vec3::UnitX();
  return Vec3(std::cos(r), std::sin(r) * u / r, std::sin(r) * v / r);
}

}  // namespace insalign::sim
