// Rigs: several LiDARs on one INS calibrated in one run (core/rig.hpp). A narrow side LiDAR that
// alone is off is fixed by the joint map with the roof LiDAR; a LiDAR whose map overlaps no other
// is refined alone and says so; the joint system's Jacobian and the LiDAR-to-LiDAR propagation are
// checked numerically; the rig outputs read back.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>

#include "cli_test_util.hpp"
#include "core/errors.hpp"
#include "core/rig.hpp"
#include "files/extrinsic_json.hpp"
#include "files/read_file.hpp"
#include "report/rig_outputs.hpp"
#include "test_world.hpp"

namespace insalign {
namespace {

// A side LiDAR: left mirror, yawed out 80 deg, tilted down 20 deg, 16 rings, only its forward
// wedge (+-45 deg) and 20 m: mostly ground and the near side of the street.
Iso3 side_mount() { return make_transform(Vec3(1.6, 0.95, 0.1), Vec3(0.0, 20.0, 80.0)); }

void keep_wedge(Dataset& data, double half_deg, double max_range_m) {
  auto load = data.frames.load;
  data.frames.load = [load, half_deg, max_range_m](std::size_t i) {
    Sweep in = load(i), out;
    out.name = in.name;
    out.t_end_s = in.t_end_s;
    for (std::size_t k = 0; k < in.size(); ++k) {
      const Vec3f& p = in.p_lidar[k];
      if (std::abs(std::atan2(p.y(), p.x())) * kDegPerRad > half_deg || p.norm() > max_range_m) continue;
      out.p_lidar.push_back(p);
      out.dt_s.push_back(in.dt_s[k]);
    }
    return out;
  };
}

struct SmallRig {
  std::vector<testing::TestDrive> drives;
  std::vector<std::string> names;
  std::vector<FrameStore> stores;
};

// roof + left on one figure-8 drive (same INS poses), each with its own clock offset; tz_error_m:
// the initial guesses' tz errors (else those of the random perturbation).
SmallRig small_rig(PipelineConfig& config, int frames = 120, const std::vector<double>& tz_error_m = {}) {
  SmallRig rig;
  testing::WorldSpec spec;
  spec.frames = frames;
  spec.T_ins_lidar = testing::roof_mount(30.0);
  spec.time_offset_s = 0.004;
  rig.drives.push_back(testing::make_test_drive(spec));
  spec.T_ins_lidar = side_mount();
  spec.time_offset_s = -0.007;
  spec.seed = 2;
  rig.drives.push_back(testing::make_test_drive(spec));
  keep_wedge(rig.drives.back().data, 45.0, 20.0);
  rig.names = {"top", "left"};
  for (std::size_t l = 0; l < rig.drives.size(); ++l) {
    Iso3 init = testing::perturbed(rig.drives[l].T_ins_lidar_true, 1.0, 0.05, 10 + l);
    if (l < tz_error_m.size()) init.translation().z() = rig.drives[l].T_ins_lidar_true.translation().z() + tz_error_m[l];
    rig.drives[l].data.T_ins_lidar_init = init;
  }
  config.ins_height_m = 1.0;  // the test world's INS height: stage 3 fixes tz
  config.repeatability.segments = 0;
  for (const auto& d : rig.drives) rig.stores.push_back(testing::store_of(d.data, config));
  return rig;
}


// One rig run shared by the tests that only read it (the machine is shared: seconds count).
struct RigRun {
  PipelineConfig config;
  SmallRig rig;
  RigResult result;
};
const RigRun& small_rig_run() {
  static const RigRun run = [] {
    RigRun r;
    r.rig = small_rig(r.config);
    r.result = run_rig_calibration(r.rig.stores, r.rig.names, r.config);
    return r;
  }();
  return run;
}

TEST(Rig, JointRefinementFixesASideLidarThatAloneIsOff) {
  const RigRun& run = small_rig_run();
  const RigResult& joint = run.result;
  const SmallRig& rig = run.rig;
  ASSERT_EQ(joint.lidars.size(), 2u);
  EXPECT_EQ(joint.lidars[1].joint_with, std::vector<std::string>{"top"});
  EXPECT_EQ(joint.lidars[0].joint_with, std::vector<std::string>{"left"});
  EXPECT_GT(joint.overlap[0][1], run.config.refine.joint.min_overlap);
  // Alone, stage 1 cannot determine the side LiDAR: the rig without the joint map stops, naming it.
  PipelineConfig alone_config = run.config;
  alone_config.refine.joint.enabled = false;
  try {
    run_rig_calibration(rig.stores, rig.names, alone_config);
    ADD_FAILURE() << "the side LiDAR alone should be undetermined";
  } catch (const UnobservableError& e) {
    EXPECT_NE(std::string(e.what()).find("LiDAR 'left'"), std::string::npos) << e.what();
    EXPECT_EQ(std::string(e.what()).find("LiDAR 'top'"), std::string::npos) << e.what();
  }
  // Alone, stage 2 from the same stage-1 start (what calibrating it by itself gives at best).
  const CalibrationResult& left = joint.lidars[1].result;
  const std::vector<std::size_t> frames = refine_frames(rig.stores[1], run.config.refine, 0.0, 0.05);
  const RefineResult alone = refine_extrinsic(rig.stores[1], frames, left.rough.T_ins_lidar, 0.0, run.config.refine);
  const ExtrinsicError a = extrinsic_error(alone.T_ins_lidar, rig.drives[1].T_ins_lidar_true);
  const ExtrinsicError j = extrinsic_error(left.T_ins_lidar, rig.drives[1].T_ins_lidar_true);
  const ExtrinsicError top = extrinsic_error(joint.lidars[0].result.T_ins_lidar, rig.drives[0].T_ins_lidar_true);
  std::printf("left alone: %.4f deg %.2f mm; jointly: %.4f deg %.2f mm (%.2f ms); top jointly %.4f deg %.2f mm\n",
              a.angle_deg, 1e3 * a.dt_norm_m, j.angle_deg, 1e3 * j.dt_norm_m, 1e3 * left.time_offset_s, top.angle_deg,
              1e3 * top.dt_norm_m);
  EXPECT_LT(j.angle_deg, 0.03);
  EXPECT_LT(j.dt_m.head<2>().maxCoeff(), 0.01);
  EXPECT_LT(top.angle_deg, 0.03);
  EXPECT_LT(top.dt_m.head<2>().maxCoeff(), 0.01);
  EXPECT_GT(a.dt_norm_m, 2.0 * j.dt_norm_m);
  for (int i : {0, 1, 3, 4, 5}) {
    EXPECT_TRUE(left.determined[i]) << kDofNames[i];
    EXPECT_TRUE(std::isfinite(left.stddev[i])) << kDofNames[i];
  }
  EXPECT_FALSE(joint.lidars[1].determined_alone[5] && joint.lidars[1].determined_alone[0]);
  ASSERT_EQ(joint.pairs.size(), 1u);
  const Iso3 T_top_left = joint.lidars[0].result.T_ins_lidar.inverse() * left.T_ins_lidar;
  EXPECT_TRUE(joint.pairs[0].T_a_b.isApprox(T_top_left, 1e-12));
  EXPECT_TRUE(joint.pairs[0].stddev.allFinite());
}

// The anchor's sweeps enter stage 2 as one LiDAR's do; a member's at most
// refine.joint.member_max_points each (here the roof's store stands in for a dense member).
TEST(Rig, AMemberBesideTheAnchorGivesStage2AtMostItsPointBudget) {
  const RigRun& run = small_rig_run();
  const CalibrationResult& top = run.result.lidars[0].result;
  ASSERT_TRUE(top.refine);
  EXPECT_EQ(run.result.lidars[1].tz_anchor, "top");
  const std::vector<std::size_t> frames = refine_frames(run.rig.stores[0], run.config.refine, top.time_offset_s, 0.05);
  const auto points_per_frame = [&](std::size_t budget) {
    RefineLidar in{"top", &run.rig.stores[0], frames, top.T_ins_lidar, top.time_offset_s, false, false, budget};
    const RefineResult r = refine_joint({in}, run.config.refine).lidars.front();
    return double(r.points_used) / double(std::max<std::size_t>(r.frames_used, 1));
  };
  const double own = points_per_frame(0), member = points_per_frame(1000);
  std::printf("top: %.0f points per frame as the anchor, %.0f with a member's budget of 1000\n", own, member);
  EXPECT_GT(own, 1500.0);
  EXPECT_LE(member, 1000.0);
  EXPECT_GT(member, 900.0);
}

// Joint stage 2 with every tz held where it started: the side LiDAR's ground sits 3 cm off the
// roof's in the shared map, and the sparse LiDAR tilts to meet it. With relative tz (the default)
// only the anchor's (the roof's, the larger map) is held, the side LiDAR's height follows the
// shared ground and its tilt stays right. No stage 3 here (no fiducials, no INS height): the
// tz errors stay the initial guesses', 0 for the roof and 3 cm for the side LiDAR.
TEST(Rig, JointRefinementMovesTheSideLidarsHeightInsteadOfTiltingIt) {
  const auto run = [](bool relative_tz) {
    PipelineConfig config;
    SmallRig rig = small_rig(config, 120, {0.0, 0.03});
    config.ins_height_m.reset();
    config.refine.joint.relative_tz = relative_tz;
    const RigResult result = run_rig_calibration(rig.stores, rig.names, config);
    EXPECT_EQ(result.lidars[1].tz_anchor, relative_tz ? "top" : "");
    const Iso3 T_top_left = result.lidars[0].result.T_ins_lidar.inverse() * result.lidars[1].result.T_ins_lidar;
    const Iso3 truth = rig.drives[0].T_ins_lidar_true.inverse() * rig.drives[1].T_ins_lidar_true;
    const ExtrinsicError left = extrinsic_error(result.lidars[1].result.T_ins_lidar, rig.drives[1].T_ins_lidar_true);
    const ExtrinsicError pair = extrinsic_error(T_top_left, truth);
    std::printf("relative tz %d: left tilt %.4f %.4f deg, yaw %.4f deg, dx %.2f dy %.2f dz %.2f mm; pair %.4f deg %.2f mm\n",
                relative_tz, left.drpy_deg.x(), left.drpy_deg.y(), left.drpy_deg.z(), 1e3 * left.dt_m.x(), 1e3 * left.dt_m.y(),
                1e3 * left.dt_m.z(), pair.angle_deg, 1e3 * pair.dt_norm_m);
    return std::pair{left, pair};
  };
  const auto [left, pair] = run(true);
  EXPECT_LT(left.drpy_deg.head<2>().maxCoeff(), 0.03);
  EXPECT_LT(left.dt_m.z(), 0.005);  // from 30 mm: the height relative to the roof's ground
  EXPECT_LT(left.dt_m.head<2>().maxCoeff(), 0.01);
  EXPECT_LT(pair.dt_norm_m, 0.01);
  // Not checked: the wedge LiDAR's yaw, 0.17-0.20 deg off with and without relative tz on this
  // drive without stage 3 (0.003 deg with the height prior, the first test): not understood yet.
  const auto [held, held_pair] = run(false);
  EXPECT_GT(held.drpy_deg.head<2>().maxCoeff(), 2.0 * left.drpy_deg.head<2>().maxCoeff());
}

// The side LiDAR's start 6 deg / 25 cm off and trusted (no data check): its own stage 1 ends 0.4
// deg / 6 cm off (alone it sees mostly ground and cannot do better), its map then overlaps the
// roof's too little to be refined jointly, and the rig stops naming it. Its sweeps registered to
// the roof's map fit 20x better 0.3 deg away; stage 1 from there goes back, so the joint stage 2
// starts from the map's extrinsic, tied to the roof, and ends within the bounds.
TEST(Rig, ALidarWhoseStage1IsOffIsStartedFromTheRoofsMap) {
  PipelineConfig config;
  SmallRig rig = small_rig(config);
  rig.drives[1].data.T_ins_lidar_init = testing::perturbed(rig.drives[1].T_ins_lidar_true, 6.0, 0.25, 21);
  config.init.trust_init = true;
  config.refine.joint.map_check.enabled = false;
  try {
    const RigResult unchecked = run_rig_calibration(rig.stores, rig.names, config);
    const ExtrinsicError off = extrinsic_error(unchecked.lidars[1].result.T_ins_lidar, rig.drives[1].T_ins_lidar_true);
    EXPECT_TRUE(off.angle_deg > 0.03 || off.dt_m.head<2>().maxCoeff() > 0.01) << off.angle_deg;
  } catch (const UnobservableError& e) {
    EXPECT_NE(std::string(e.what()).find("LiDAR 'left'"), std::string::npos) << e.what();
  }
  config.refine.joint.map_check.enabled = true;
  const RigResult result = run_rig_calibration(rig.stores, rig.names, config);
  const RigLidar& left = result.lidars[1];
  const RigMapCheck& check = left.map_check;
  const ExtrinsicError e = extrinsic_error(left.result.T_ins_lidar, rig.drives[1].T_ins_lidar_true);
  const ExtrinsicError m = extrinsic_error(check.T_ins_lidar_map, rig.drives[1].T_ins_lidar_true);
  std::printf("left %.4f deg, dx %.2f dy %.2f mm; the map's extrinsic %.4f deg, moved %.3f deg %.1f mm, RMS %.1f -> %.1f mm\n",
              e.angle_deg, 1e3 * e.dt_m.x(), 1e3 * e.dt_m.y(), m.angle_deg, check.moved_rot_deg, 1e3 * check.moved_xy_m,
              1e3 * check.rms_before_m, 1e3 * check.rms_after_m);
  EXPECT_LT(e.angle_deg, 0.03);
  EXPECT_LT(e.dt_m.head<2>().maxCoeff(), 0.01);
  EXPECT_EQ(check.reference, "top");
  EXPECT_TRUE(check.map_start);
  EXPECT_FALSE(check.restarted);
  EXPECT_GT(check.moved_rot_deg, 0.2);
  EXPECT_LT(m.angle_deg, 0.2);  // stage 1's bound
  EXPECT_LT(config.refine.joint.map_check.min_fit_gain * check.rms_after_m, check.rms_before_m);
  EXPECT_EQ(left.joint_with, std::vector<std::string>{"top"});
  bool said = false;
  for (const std::string& w : left.result.warnings) said = said || w.find("starts from the map's extrinsic") != std::string::npos;
  EXPECT_TRUE(said);
  EXPECT_TRUE(result.lidars[0].map_check.reference.empty());  // the reference itself
}

// A second full-view LiDAR whose stage 1 stops short (a one-step schedule from 3 deg off): it is
// determined alone, so the check does not start the joint stage 2 from the map but runs its stage 1
// again from the map's extrinsic, and keeps that because it fits the roof's map better.
TEST(Rig, ALidarWhoseStage1StoppedShortRunsItAgainFromTheMap) {
  PipelineConfig config;
  config.ins_height_m = 1.0;
  config.repeatability.segments = 0;
  config.init.trust_init = true;
  config.rough.rounds = {{0, 2, 1.0, 0.04, 0.05, 1}};  // whole drive, tight voxels, one step
  testing::WorldSpec spec;
  spec.frames = 120;
  spec.T_ins_lidar = testing::roof_mount(30.0);
  std::vector<testing::TestDrive> drives = {testing::make_test_drive(spec)};
  spec.T_ins_lidar = make_transform(Vec3(-0.4, -0.3, 0.9), Vec3(0.0, 3.0, -100.0));
  spec.seed = 3;
  drives.push_back(testing::make_test_drive(spec));
  drives[0].data.T_ins_lidar_init = testing::perturbed(drives[0].T_ins_lidar_true, 0.02, 0.002, 5);
  drives[1].data.T_ins_lidar_init = testing::perturbed(drives[1].T_ins_lidar_true, 3.0, 0.15, 6);
  std::vector<FrameStore> stores;
  for (const testing::TestDrive& d : drives) stores.push_back(testing::store_of(d.data, config));

  const RigResult rig = run_rig_calibration(stores, {"top", "back"}, config);
  const RigMapCheck& check = rig.lidars[1].map_check;
  const ExtrinsicError rough = extrinsic_error(rig.lidars[1].result.rough.T_ins_lidar, drives[1].T_ins_lidar_true);
  const ExtrinsicError e = extrinsic_error(rig.lidars[1].result.T_ins_lidar, drives[1].T_ins_lidar_true);
  std::printf("back: moved %.3f deg %.1f mm, RMS %.1f -> %.1f, restarted %.1f mm; stage 1 %.4f deg, final %.4f deg "
              "dx %.2f dy %.2f mm\n",
              check.moved_rot_deg, 1e3 * check.moved_xy_m, 1e3 * check.rms_before_m, 1e3 * check.rms_after_m,
              1e3 * check.rms_restarted_m, rough.angle_deg, e.angle_deg, 1e3 * e.dt_m.x(), 1e3 * e.dt_m.y());
  EXPECT_EQ(check.reference, "top");
  EXPECT_GT(check.moved_rot_deg, 0.2);
  EXPECT_TRUE(check.restarted);
  EXPECT_FALSE(check.map_start);
  EXPECT_LT(check.rms_restarted_m * config.refine.joint.map_check.min_fit_gain, check.rms_before_m);
  EXPECT_LT(rough.angle_deg, 0.2);  // the stage 1 kept is the restarted one
  EXPECT_LT(e.angle_deg, 0.03);
  EXPECT_LT(e.dt_m.head<2>().maxCoeff(), 0.01);
  bool said = false;
  for (const std::string& w : rig.lidars[1].result.warnings) said = said || w.find("stage 1 restarted") != std::string::npos;
  EXPECT_TRUE(said);
}

TEST(Rig, ALidarThatOverlapsNoOtherIsCalibratedAloneAndSaysSo) {
  PipelineConfig config;
  config.ins_height_m = 1.0;
  config.repeatability.segments = 0;
  testing::WorldSpec spec;
  spec.frames = 120;
  spec.T_ins_lidar = testing::roof_mount(30.0);
  std::vector<testing::TestDrive> drives = {testing::make_test_drive(spec)};
  spec.T_ins_lidar = testing::roof_mount(-100.0);
  spec.seed = 3;
  drives.push_back(testing::make_test_drive(spec));
  // The second LiDAR's poses place its map 500 m away: nothing it sees is in the first one's map.
  std::vector<StampedPose> shifted;
  for (const StampedPose& p : drives[1].data.poses.poses()) {
    StampedPose q = p;
    q.T_world_ins.translation().x() += 500.0;
    shifted.push_back(q);
  }
  drives[1].data.poses = PoseStream(std::move(shifted));
  std::vector<FrameStore> stores;
  for (testing::TestDrive& d : drives) {
    d.data.T_ins_lidar_init = testing::perturbed(d.T_ins_lidar_true, 1.0, 0.05, 7);
    stores.push_back(testing::store_of(d.data, config));
  }
  const RigResult rig = run_rig_calibration(stores, {"a", "far"}, config);
  EXPECT_LT(rig.overlap[0][1], config.refine.joint.min_overlap);
  for (std::size_t l = 0; l < 2; ++l) {
    EXPECT_TRUE(rig.lidars[l].joint_with.empty());
    EXPECT_NE(rig.lidars[l].joint_note.find("overlaps no other LiDAR"), std::string::npos) << rig.lidars[l].joint_note;
    const ExtrinsicError e = extrinsic_error(rig.lidars[l].result.T_ins_lidar, drives[l].T_ins_lidar_true);
    EXPECT_LT(e.angle_deg, 0.05) << l;
    EXPECT_LT(e.dt_m.head<2>().maxCoeff(), 0.01) << l;
  }
  EXPECT_NE(rig.lidars[0].group, rig.lidars[1].group);
}

TEST(Rig, OutputsRoundTrip) {
  const RigRun& run = small_rig_run();
  const std::filesystem::path out = std::filesystem::temp_directory_path() / ("insalign_rig_test_" + std::to_string(::getpid()));
  std::filesystem::remove_all(out);
  const std::vector<io::RunInfo> runs(2);
  io::write_rig_outputs(out, run.result, run.rig.stores, runs, run.config, {});
  for (const char* f : {"rig.json", "rig.urdf", "report.html", "top/extrinsic.json", "left/extrinsic.json",
                        "left/gnss-to-lidar-extrinsic.json", "left/report.html", "left/extrinsic.urdf.xacro"})
    EXPECT_TRUE(std::filesystem::exists(out / f)) << f;
  const std::string text = io::read_file(out / "rig.json");
  const io::RigFile file = io::parse_rig_json(text, "rig.json");
  ASSERT_EQ(file.lidars.size(), 2u);
  for (const io::RigFileLidar& l : file.lidars) {
    const std::size_t i = l.name == "top" ? 0 : 1;
    const CalibrationResult& r = run.result.lidars[i].result;
    EXPECT_TRUE(l.T_ins_lidar.isApprox(r.T_ins_lidar, 1e-12)) << l.name;
    EXPECT_DOUBLE_EQ(l.time_offset_s, r.time_offset_s);
    EXPECT_EQ(l.determined, r.determined);
    for (int d = 0; d < 6; ++d) EXPECT_NEAR(l.stddev[d], r.stddev[d], 1e-12 + 1e-9 * std::abs(r.stddev[d])) << d;
  }
  ASSERT_EQ(file.pairs.size(), 1u);
  EXPECT_EQ(file.pairs[0].a, "top");
  EXPECT_EQ(file.pairs[0].b, "left");
  EXPECT_TRUE(file.pairs[0].T_a_b.isApprox(run.result.pairs[0].T_a_b, 1e-12));
  // Each LiDAR's own extrinsic.json says which LiDAR's height its tz was measured against.
  for (std::size_t i = 0; i < 2; ++i) {
    const RigLidar& lidar = run.result.lidars[i];
    const auto j = nlohmann::json::parse(io::read_file(out / lidar.name / "extrinsic.json"));
    EXPECT_EQ(j["rig"]["tz_anchor"].is_null(), lidar.tz_anchor.empty()) << lidar.name;
    if (!lidar.tz_anchor.empty()) {
      EXPECT_EQ(j["rig"]["tz_anchor"].get<std::string>(), lidar.tz_anchor);
    }
    EXPECT_EQ(j["rig"]["tz_from_anchor"].get<bool>(), lidar.tz_from_anchor);
    EXPECT_EQ(j["rig"]["map_check"].is_null(), lidar.map_check.reference.empty()) << lidar.name;
    // The screening: which LiDAR's checks left INS spans out, and this LiDAR's own mask.
    EXPECT_EQ(j["rig"]["ins_checks_by"].get<std::string>(), "top") << lidar.name;
    EXPECT_EQ(j["left_out"]["moving_points"]["applied"].get<bool>(), lidar.result.moving.applied) << lidar.name;
    if (!lidar.map_check.reference.empty()) {
      EXPECT_EQ(j["rig"]["map_check"]["map_start"].get<bool>(), lidar.map_check.map_start) << lidar.name;
    }
  }
  const std::string urdf = io::read_file(out / "rig.urdf");
  EXPECT_NE(urdf.find("<joint name=\"ins_to_top\""), std::string::npos);
  EXPECT_NE(urdf.find("<joint name=\"ins_to_left\""), std::string::npos);
  const std::string html = io::read_file(out / "report.html");
  EXPECT_NE(html.find("LiDAR 'left'"), std::string::npos);
  EXPECT_NE(html.find("rig_final_top.png"), std::string::npos);
  EXPECT_NE(html.find("left out: 0.0 s of INS time in 0 spans (LiDAR checks by &#39;top&#39;)"), std::string::npos);
  EXPECT_THROW(io::parse_rig_json("{\"lidars\": {\"a\": {}}}", "bad.json"), InputError);
  std::filesystem::remove_all(out);
}

// simulate --rig, then calibrate with one --lidar-dir and --init per LiDAR: rig.json read back and
// compared with ground_truth.json's "lidars" (coarse: 2 deg columns, 40 s, two LiDARs).
TEST(Rig, EndToEndFromTheSimulatorThroughTheCommandLine) {
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / ("insalign_rig_e2e_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  const auto run = [](const std::string& args) { return testing::run_command(std::string(INSALIGN_EXE) + " " + args); };
  const std::string sim = (dir / "sim").string();
  auto [rc, out] = run("simulate --quiet --seed 5 --rig top:pandar64,left:vlp16@left --azimuth-step-deg 1 --duration-s 40 --out " + sim);
  ASSERT_EQ(rc, 0) << out;
  std::tie(rc, out) = run("calibrate --quiet --no-report --segments 0 --lidar-dir " + sim + "/lidar/top --lidar-dir " + sim +
                          "/lidar/left --poses " + sim + "/poses_tum.txt --init " + sim + "/init-extrinsic-top.json --init " +
                          sim + "/init-extrinsic-left.json --fiducials " + sim + "/fiducials.txt --out " + (dir / "out").string());
  ASSERT_EQ(rc, 0) << out;
  const io::RigFile rig = io::parse_rig_json(io::read_file(dir / "out/rig.json"), "rig.json");
  const nlohmann::json truth = nlohmann::json::parse(io::read_file(dir / "sim/ground_truth.json"));
  ASSERT_EQ(rig.lidars.size(), 2u);
  for (const io::RigFileLidar& l : rig.lidars) {
    const Iso3 T_true = io::transform_from_json(truth.at("lidars").at(l.name).at("T_ins_lidar"), "ground_truth.json");
    const ExtrinsicError e = extrinsic_error(l.T_ins_lidar, T_true);
    std::printf("%s: %.4f deg, dx %.2f dy %.2f mm\n", l.name.c_str(), e.angle_deg, 1e3 * e.dt_m.x(), 1e3 * e.dt_m.y());
    EXPECT_LT(e.angle_deg, 0.1) << l.name;
    EXPECT_LT(e.dt_m.head<2>().maxCoeff(), 0.02) << l.name;
    EXPECT_TRUE(std::filesystem::exists(dir / "out" / l.name / "extrinsic.json")) << l.name;
  }
  std::filesystem::remove_all(dir);
}

TEST(Rig, PairUncertaintyMatchesNumericPropagation) {
  const Iso3 T_a = make_transform(Vec3(0.3, -0.2, 1.1), Vec3(2.0, -1.0, 40.0));
  const Iso3 T_b = make_transform(Vec3(1.6, 0.9, 0.2), Vec3(-3.0, 18.0, 85.0));
  Eigen::Matrix<double, 12, 12> C = Eigen::Matrix<double, 12, 12>::Identity();
  const LidarPair p = lidar_pair(T_a, T_b, C);
  // Numeric Jacobian of the pair's 6-vector in each of the 12 perturbations.
  Eigen::Matrix<double, 6, 12> J;
  const double h = 1e-6;
  for (int k = 0; k < 12; ++k) {
    Vec6 d = Vec6::Zero();
    d[k % 6] = h;
    const Iso3 Ta = k < 6 ? perturb_in_ins_frame(T_a, d) : T_a, Tb = k < 6 ? T_b : perturb_in_ins_frame(T_b, d);
    const Iso3 T = Ta.inverse() * Tb;
    J.col(k).head<3>() = (T.translation() - p.T_a_b.translation()) / h;
    J.col(k).tail<3>() = so3_log(T.linear() * p.T_a_b.linear().transpose()) / h;
  }
  const Mat6 numeric = J * J.transpose();
  EXPECT_LT((numeric - p.covariance).cwiseAbs().maxCoeff(), 1e-4) << numeric << "\n\n" << p.covariance;
}

TEST(Rig, JointSystemGradientMatchesNumericDifferentiation) {
  testing::WorldSpec spec;
  spec.frames = 80;
  spec.lidar.noise_m = 0.0;
  spec.T_ins_lidar = testing::roof_mount(40.0);
  const testing::TestDrive a = testing::make_test_drive(spec);
  spec.T_ins_lidar = side_mount();
  spec.seed = 5;
  const testing::TestDrive b = testing::make_test_drive(spec);
  const FrameStore sa = testing::store_of(a.data), sb = testing::store_of(b.data);
  RefineConfig config;
  config.huber_m = 1e3;
  config.max_frames = 20;
  const std::vector<RefineLidar> lidars = {{"a", &sa, refine_frames(sa, config, 0.0, 0.05), Iso3::Identity(), 0.0, true},
                                           {"b", &sb, refine_frames(sb, config, 0.0, 0.05), Iso3::Identity(), 0.0, true}};
  const std::vector<std::pair<Iso3, double>> x0 = {{testing::perturbed(a.T_ins_lidar_true, 0.3, 0.03, 4), 0.004},
                                                   {testing::perturbed(b.T_ins_lidar_true, 0.3, 0.03, 6), -0.003}};
  const double h[7] = {1e-4, 1e-4, 1e-4, 2e-6, 2e-6, 2e-6, 1e-5};
  std::vector<std::vector<std::pair<Iso3, double>>> states = {x0};
  for (int p = 0; p < 2 * kRefineParams; ++p) {
    for (double sign : {+1.0, -1.0}) {
      auto x = x0;
      const int l = p / kRefineParams, i = p % kRefineParams;
      Vec6 d = Vec6::Zero();
      if (i < 6) d[i] = sign * h[i];
      x[l] = {perturb_in_ins_frame(x0[l].first, d), x0[l].second + (i == 6 ? sign * h[i] : 0.0)};
      states.push_back(x);
    }
  }
  const std::vector<JointRefineSystem> sys = refine_joint_systems(lidars, states, config);
  ASSERT_GT(sys[0].points, 1000u);
  for (int p = 0; p < 2 * kRefineParams; ++p) {
    const double numeric = 0.5 * (sys[1 + 2 * p].cost - sys[2 + 2 * p].cost) / (2.0 * h[p % kRefineParams]);
    // 1 %: the rotation columns use the INS pose of the nearest 10 ms knot (the side LiDAR's yaw
    // column is 0.7 % off on this drive; tests/jacobian_test.cpp allows 0.5 % for the roof alone).
    EXPECT_NEAR(sys[0].gradient[p], numeric, 0.01 * std::abs(numeric) + 1e-3) << "parameter " << p;
  }
  // The cross blocks exist (planes shared by both LiDARs) and the Hessian is symmetric.
  const Eigen::MatrixXd cross = sys[0].hessian.block(0, 7, 7, 7);
  EXPECT_GT(cross.cwiseAbs().maxCoeff(), 0.0);
  EXPECT_LT((sys[0].hessian - sys[0].hessian.transpose()).cwiseAbs().maxCoeff(), 1e-9 * sys[0].hessian.cwiseAbs().maxCoeff());
}

}  // namespace
}  // namespace insalign
