// Rigs: the --rig specification, every LiDAR seeing the scene from its own mount (within its field
// of view, never its own car), its own clock and spin, the Livox rosette filling its field of view
// over frames, the in-memory access per LiDAR and the written layout.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <nlohmann/json.hpp>
#include <set>

#include "cli_test_util.hpp"
#include "sim/lidar_model.hpp"
#include "sim/rig.hpp"
#include "sim/simulate.hpp"
#include "sim/world_dataset.hpp"

namespace insalign::sim {
namespace {

namespace fs = std::filesystem;

constexpr const char* kRig = "top:pandar64,left:vlp16@left,right:vlp16@right,front:os1-64@front,solid:livox-avia@roof-front";

SimConfig rig_config(std::uint64_t seed = 4) {
  SimConfig c;
  c.seed = seed;
  c.duration_s = 3.0;
  c.azimuth_step_deg = 1.0;
  c.rig = kRig;
  return c;
}

TEST(SimRig, SpecificationIsParsedAndBadEntriesAreNamed) {
  const auto rig = parse_rig("top:pandar64,left:vlp16@left,front:os1-64@front/20");
  ASSERT_EQ(rig.size(), 3u);
  EXPECT_EQ(rig[0].name, "top");
  EXPECT_EQ(rig[0].model, "pandar64");
  EXPECT_EQ(rig[0].mount, "roof");
  EXPECT_EQ(rig[1].mount, "left");
  EXPECT_EQ(rig[2].frame_rate_hz, 20.0);
  for (const char* bad : {"top", "top:pandar64,top:vlp16", "a:vlp16@wing", "a:vlp16/0", "a b:vlp16", ""}) {
    EXPECT_THROW(parse_rig(bad), std::invalid_argument) << bad;
  }
  SimConfig c = rig_config();
  c.rig = "top:pandar99";
  EXPECT_THROW(build_world(c), std::invalid_argument);
}

// Points of frame k of LiDAR i in the vehicle frame of each point's own instant.
std::vector<Vec3> vehicle_points(const World& w, std::size_t i, std::size_t k) {
  const Iso3 T_vehicle_lidar = w.T_vehicle_ins * w.lidars[i].T_ins_lidar_true;
  std::vector<Vec3> out;
  for (const Vec3f& p : render_lidar_sweep(w, i, k).p_lidar) out.push_back(T_vehicle_lidar * p.cast<double>());
  return out;
}

double fraction(const std::vector<Vec3>& pts, const std::function<bool(const Vec3&)>& pred) {
  std::size_t n = 0;
  for (const Vec3& p : pts) n += pred(p);
  return pts.empty() ? 0.0 : static_cast<double>(n) / static_cast<double>(pts.size());
}

TEST(SimRig, EveryLidarSeesTheSceneFromItsMountAndNeverItsOwnCar) {
  const World w = build_world(rig_config());
  ASSERT_EQ(w.lidars.size(), 5u);
  std::set<double> offsets;
  const double ground_z = -w.ins_height_m;  // the ground in the vehicle frame (nearly flat)
  for (std::size_t i = 0; i < w.lidars.size(); ++i) {
    const SimLidar& l = w.lidars[i];
    offsets.insert(l.time_offset_s);
    EXPECT_LE(std::abs(l.time_offset_s), 0.03 + 1e-12);
    const std::vector<Vec3> pts = vehicle_points(w, i, 10);
    ASSERT_GT(pts.size(), 1000u) << l.name;
    // Nothing on the car's own body (x -1.1..3.6 m, half width 0.95 m, up to 1.55 m high).
    EXPECT_EQ(fraction(pts, [&](const Vec3& p) {
                return p.x() > EgoBody::kRearM + 0.05 && p.x() < EgoBody::kFrontM - 0.05 &&
                       std::abs(p.y()) < EgoBody::kHalfWidthM - 0.05 && p.z() - ground_z < EgoBody::kTopM - 0.05 &&
                       p.z() - ground_z > EgoBody::kBottomM + 0.05;
              }), 0.0) << l.name;
    if (l.model.pattern == ScanPattern::kSpinning) {  // within its beams' elevations
      const auto [lo, hi] = std::minmax_element(l.model.elevation_deg.begin(), l.model.elevation_deg.end());
      for (const Vec3f& p : render_lidar_sweep(w, i, 10).p_lidar) {
        const double el = std::asin(p.z() / p.norm()) * kDegPerRad;
        ASSERT_GE(el, *lo - 0.01) << l.name;
        ASSERT_LE(el, *hi + 0.01) << l.name;
      }
    }
    const double height = (w.T_vehicle_ins * l.T_ins_lidar_true).translation().z() - ground_z;
    const auto on_ground = [&](const Vec3& p) { return std::abs(p.z() - ground_z) < 0.25; };
    if (l.name == "top") {
      EXPECT_GT(height, 1.75);
      EXPECT_LT(height, 2.25);
    } else if (l.name == "left" || l.name == "right") {
      const double side = l.name == "left" ? 1.0 : -1.0;
      EXPECT_GT(height, 0.95);
      EXPECT_LT(height, 2.0);
      const double own_side = fraction(pts, [&](const Vec3& p) { return side * p.y() > 0.0; });
      if (height < 1.3) {  // a mirror: tilted down and outward, the body hides the far side
        EXPECT_GT(fraction(pts, on_ground), 0.5) << l.name;
        EXPECT_GT(own_side, 0.9) << l.name;
      } else {  // a roof edge also sees over the roof
        EXPECT_GT(own_side, 0.55) << l.name;
      }
    } else if (l.name == "front") {
      EXPECT_GT(height, 0.4);
      EXPECT_LT(height, 0.65);
      EXPECT_GT(fraction(pts, [](const Vec3& p) { return p.x() > 3.0; }), 0.9);
    } else {  // solid-state: every point inside its 70.4 deg cone
      const Sweep s = render_lidar_sweep(w, i, 10);
      for (const Vec3f& p : s.p_lidar) ASSERT_LT(std::acos(p.x() / p.norm()) * kDegPerRad, 35.2 + 0.05);
      EXPECT_GT(fraction(pts, [](const Vec3& p) { return p.x() > 2.0; }), 0.95);
    }
  }
  EXPECT_EQ(offsets.size(), w.lidars.size()) << "every LiDAR on its own clock";
}

TEST(SimRig, EachLidarHasItsOwnClockSpinAndFrames) {
  const World w = build_world(rig_config());
  const SimLidar& top = w.lidars[0];
  const SimLidar& left = w.lidars[1];
  EXPECT_NE(top.start_azimuth_rad, left.start_azimuth_rad);
  EXPECT_NE(top.frame_times_s.front(), left.frame_times_s.front()) << "frame phases differ";
  EXPECT_EQ(w.frame_times_s, top.frame_times_s);
  EXPECT_TRUE(w.T_ins_lidar_true.isApprox(top.T_ins_lidar_true));
  // The in-memory dataset of one rig LiDAR carries its own frames, clock offset and guess.
  SimConfig c = rig_config();
  c.duration_s = 0.5;
  const World small = build_world(c);
  const SimDataset left_data = simulate_lidar(small, 1);
  ASSERT_EQ(left_data.sweeps.size(), 5u);
  EXPECT_EQ(left_data.time_offset_s, small.lidars[1].time_offset_s);
  EXPECT_TRUE(left_data.T_ins_lidar_true.isApprox(small.lidars[1].T_ins_lidar_true));
  for (const Sweep& s : left_data.sweeps) {
    EXPECT_LE(*std::max_element(s.ring.begin(), s.ring.end()), 15) << "a VLP-16";
    // Within one revolution; the half facing the car body and the sky returns nothing.
    EXPECT_GE(*std::min_element(s.dt_s.begin(), s.dt_s.end()), -0.1f);
    EXPECT_LT(*std::min_element(s.dt_s.begin(), s.dt_s.end()), -0.03f);
  }
  const Dataset d = world_dataset(std::make_shared<const World>(small), 4);
  EXPECT_EQ(d.frames.frames.size(), small.lidars[4].frame_times_s.size());
  EXPECT_TRUE(d.T_ins_lidar_init->isApprox(small.lidars[4].T_ins_lidar_init));
  EXPECT_EQ(d.frames.load(0).size(), render_lidar_sweep(small, 4, 0).size());
}

// Fraction of 1-deg cells of the rosette's field of view hit by the first `frames` frames.
double rosette_coverage(const LidarModel& m, int frames) {
  const int n = static_cast<int>(m.fov_deg) + 1;
  std::vector<std::uint8_t> hit(static_cast<std::size_t>(n * n), 0);
  const int firings = static_cast<int>(m.point_rate_hz / m.lines * 0.1);
  for (int f = 0; f < frames * firings; ++f)
    for (int l = 0; l < m.lines; ++l) {
      const Vec3 d = rosette_direction(m, l, f * 0.1 / firings);
      const int u = static_cast<int>(std::floor(std::atan2(d.y(), d.x()) * kDegPerRad + n / 2.0));
      const int v = static_cast<int>(std::floor(std::atan2(d.z(), d.x()) * kDegPerRad + n / 2.0));
      if (u >= 0 && v >= 0 && u < n && v < n) hit[static_cast<std::size_t>(v * n + u)] = 1;
    }
  // Cells inside the circular field of view.
  std::size_t inside = 0, covered = 0;
  for (int v = 0; v < n; ++v)
    for (int u = 0; u < n; ++u) {
      if (std::hypot(u + 0.5 - n / 2.0, v + 0.5 - n / 2.0) > m.fov_deg / 2.0 - 1.0) continue;
      ++inside;
      covered += hit[static_cast<std::size_t>(v * n + u)];
    }
  return static_cast<double>(covered) / static_cast<double>(inside);
}

TEST(SimRig, LivoxRosetteFillsItsFieldOfViewOverFrames) {
  const LidarModel m = lidar_model("livox-avia");
  ASSERT_EQ(m.pattern, ScanPattern::kRosette);
  const double one = rosette_coverage(m, 1), three = rosette_coverage(m, 3), ten = rosette_coverage(m, 10);
  RecordProperty("coverage_1_frame", std::to_string(one));
  RecordProperty("coverage_10_frames", std::to_string(ten));
  EXPECT_GT(one, 0.2);
  EXPECT_LT(one, 0.8);  // a single frame leaves gaps ...
  EXPECT_GT(three, one + 0.1);
  EXPECT_GT(ten, 0.9);  // ... which the next frames fill: the pattern does not repeat
  // Every direction within the cone.
  for (int f = 0; f < 20000; ++f)
    for (int l = 0; l < m.lines; ++l)
      ASSERT_LE(std::acos(rosette_direction(m, l, f * 1e-5).x()) * kDegPerRad, 35.2 + 1e-9);
}

using testing::RunResult;
const auto& run = testing::run_insalign;

TEST(SimRig, SimulateWritesOneFolderPerLidarAndTheRigGroundTruth) {
  const fs::path dir = fs::temp_directory_path() / ("insalign_rig_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  const RunResult r = run("simulate --quiet --seed 5 --frames 3 --azimuth-step-deg 4 --out " + dir.string() +
                          " --rig top:pandar64,left:vlp16@left,front:os1-64@front/20");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  for (const char* name : {"top", "left", "front"}) {
    std::size_t pcds = 0;
    for (const auto& e : fs::directory_iterator(dir / "lidar" / name)) pcds += e.path().extension() == ".pcd";
    EXPECT_EQ(pcds, std::string(name) == "front" ? 6u : 3u) << name;  // front runs at 20 Hz
    EXPECT_TRUE(fs::exists(dir / ("init-extrinsic-" + std::string(name) + ".json")));
    EXPECT_TRUE(fs::exists(dir / ("poses-" + std::string(name) + ".txt")));
  }
  EXPECT_FALSE(fs::exists(dir / "init-extrinsic.json"));
  std::ifstream in(dir / "ground_truth.json");
  const nlohmann::json gt = nlohmann::json::parse(in);
  ASSERT_TRUE(gt.contains("lidars"));
  EXPECT_EQ(gt["lidars"].size(), 3u);
  EXPECT_EQ(gt["lidars"]["left"]["model"], "vlp16");
  EXPECT_EQ(gt["lidars"]["top"]["T_ins_lidar"], gt["T_ins_lidar"]) << "top-level keys are the first LiDAR's";
  EXPECT_EQ(gt["lidars"]["top"]["time_offset_s"], gt["time_offset_s"]);
  EXPECT_NE(gt["lidars"]["left"]["time_offset_s"], gt["lidars"]["front"]["time_offset_s"]);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace insalign::sim
