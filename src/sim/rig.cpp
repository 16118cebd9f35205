#include "sim/rig.hpp"

#include <algorithm>
#include <cctype>
#include <set>
#include <sstream>
#include <stdexcept>

namespace insalign::sim {
namespace {

constexpr double kBodyFrontM = EgoBody::kFrontM, kBodyRearM = EgoBody::kRearM;

bool valid_name(const std::string& n) {
  return !n.empty() && std::all_of(n.begin(), n.end(), [](unsigned char c) { return std::isalnum(c) || c == '-' || c == '_'; });
}

RigLidarSpec parse_entry(const std::string& entry) {
  auto fail = [&](const std::string& why) { throw std::invalid_argument("--rig entry \"" + entry + "\": " + why); };
  RigLidarSpec s;
  const auto colon = entry.find(':');
  if (colon == std::string::npos) fail("expected name:model[@mount][/rate_hz]");
  s.name = entry.substr(0, colon);
  std::string rest = entry.substr(colon + 1);
  if (const auto slash = rest.find('/'); slash != std::string::npos) {
    std::istringstream in(rest.substr(slash + 1));
    if (!(in >> s.frame_rate_hz) || !in.eof() || !(s.frame_rate_hz >= 1.0 && s.frame_rate_hz <= 50.0))
      fail("the frame rate after '/' must be a number of Hz in [1, 50]");
    rest = rest.substr(0, slash);
  }
  if (const auto at = rest.find('@'); at != std::string::npos) {
    s.mount = rest.substr(at + 1);
    rest = rest.substr(0, at);
  }
  s.model = rest;
  if (!valid_name(s.name)) fail("the name must be letters, digits, '-' or '_'");
  const auto presets = mount_presets();
  if (std::find(presets.begin(), presets.end(), s.mount) == presets.end())
    fail("unknown mount \"" + s.mount + "\" (roof, left, right, front, rear, roof-front)");
  return s;
}

}  // namespace

Box EgoBody::box(double ins_height_m) {
  Box b;
  b.center_m = Vec3(0.5 * (kRearM + kFrontM), 0.0, 0.5 * (kBottomM + kTopM) - ins_height_m);
  b.half_m = Vec3(0.5 * (kFrontM - kRearM), kHalfWidthM, 0.5 * (kTopM - kBottomM));
  b.kind = BoxKind::kCar;
  return b;
}

std::vector<std::string> mount_presets() { return {"roof", "left", "right", "front", "rear", "roof-front"}; }

std::vector<RigLidarSpec> parse_rig(const std::string& spec) {
  std::vector<RigLidarSpec> out;
  std::set<std::string> names;
  std::istringstream in(spec);
  for (std::string entry; std::getline(in, entry, ',');) {
    if (entry.empty()) continue;
    out.push_back(parse_entry(entry));
    if (!names.insert(out.back().name).second) throw std::invalid_argument("--rig names \"" + out.back().name + "\" twice");
  }
  if (out.empty()) throw std::invalid_argument("--rig lists no LiDAR (name:model[@mount],...)");
  if (out.size() > 16) throw std::invalid_argument("--rig lists more than 16 LiDARs");
  return out;
}

Iso3 random_vehicle_mount(const std::string& preset, Rng& rng, double ins_height_m) {
  // Draws in a fixed order (one per statement: argument evaluation order is unspecified).
  double d[6];
  auto draw = [&](std::initializer_list<std::pair<double, double>> ranges) {
    int i = 0;
    for (const auto& [lo, hi] : ranges) d[i++] = rng.uniform(lo, hi);
  };
  double side = 1.0;
  if (preset == "roof") {  // as the single LiDAR's random roof mount
    draw({{0.3, 1.5}, {-0.3, 0.3}, {1.8, 2.2}, {-10.0, 10.0}, {-10.0, 10.0}, {-180.0, 180.0}});
  } else if (preset == "left" || preset == "right") {
    side = preset == "left" ? 1.0 : -1.0;
    if (rng.uniform() < 0.3) {  // roof edge, above the body: it also sees across, over the roof
      draw({{0.8, 2.0}, {0.75, 0.9}, {1.7, 1.95}, {-3.0, 3.0}, {10.0, 25.0}, {45.0, 90.0}});
    } else {  // mirror, beside the body: the body hides the other side
      draw({{1.9, 2.3}, {1.0, 1.1}, {1.0, 1.2}, {-3.0, 3.0}, {10.0, 25.0}, {45.0, 90.0}});
    }
    // Yawed outward; positive pitch tips the sensor's x axis down toward the ground beside the car.
    d[1] *= side;
    d[5] *= side;
  } else if (preset == "front") {
    draw({{kBodyFrontM + 0.05, kBodyFrontM + 0.25}, {-0.1, 0.1}, {0.45, 0.6}, {-2.0, 2.0}, {2.0, 8.0}, {-3.0, 3.0}});
  } else if (preset == "rear") {
    draw({{kBodyRearM - 0.2, kBodyRearM - 0.05}, {-0.1, 0.1}, {0.5, 0.9}, {-2.0, 2.0}, {2.0, 8.0}, {177.0, 183.0}});
  } else if (preset == "roof-front") {
    draw({{1.8, 2.2}, {-0.2, 0.2}, {1.75, 1.95}, {-2.0, 2.0}, {3.0, 10.0}, {-3.0, 3.0}});
  } else {
    throw std::invalid_argument("unknown mount preset \"" + preset + "\"");
  }
  // Heights above the ground -> the INS-origin vehicle frame.
  return make_transform(Vec3(d[0], d[1], d[2] - ins_height_m), Vec3(d[3], d[4], d[5]));
}

}  // namespace insalign::sim
