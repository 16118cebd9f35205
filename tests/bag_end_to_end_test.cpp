// The same simulated drive as a PCD folder (as `insalign simulate` writes it) and as each recording
// format (sim/export/sim_bag_export.hpp), with each LiDAR time convention and each INS message type
// across the runs: the Datasets must hold the same sweeps and, up to the message type's `ins`
// frame, the same poses; calibrating from the PCD folder and from a recording gives the same answer.
#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "sim/export/sim_bag_export.hpp"
#include "cli_test_util.hpp"
#include "core/errors.hpp"
#include "core/pipeline.hpp"
#include "input/bag_dataset.hpp"
#include "input/dataset.hpp"
#include "files/extrinsic_json.hpp"
#include "files/fiducials.hpp"
#include "pointcloud/pcd.hpp"
#include "files/poses.hpp"
#include "files/read_file.hpp"
#include "sim/simulate.hpp"

namespace insalign {
namespace {

namespace fs = std::filesystem;
using cli::InsMessage;
using cli::LidarConvention;
using io::bag::BagFormat;
using io::bag::Compression;

testing::ScratchDir scratch_dir(const std::string& tag) { return {"insalign_bag_e2e_", tag}; }

// The PCD folder exactly as cmd_simulate writes it (binary PCDs with absolute timestamps, the
// 100 Hz TUM pose file, init-extrinsic.json, fiducials.txt), read back through load_dataset.
Dataset write_and_load_pcd(const sim::World& world, const fs::path& dir) {
  fs::create_directories(dir / "lidar");
  for (std::size_t k = 0; k < world.frame_count(); ++k) {
    const Sweep s = sim::render_sweep(world, k);
    io::write_pcd(dir / "lidar" / (s.name + ".pcd"), s, io::PcdEncoding::kBinaryCompressed, io::PcdTimeField::kAbsolute);
  }
  io::write_tum_poses(dir / "poses_tum.txt", sim::dense_reported_poses(world, 100.0));
  io::write_opencalib_extrinsic(dir / "init-extrinsic.json", world.T_ins_lidar_init);
  io::write_fiducials(dir / "fiducials.txt", world.fiducials);
  io::DatasetPaths paths;
  paths.lidar_dir = dir / "lidar";
  paths.poses = dir / "poses_tum.txt";
  paths.init = dir / "init-extrinsic.json";
  paths.fiducials = dir / "fiducials.txt";
  return io::load_dataset(paths);
}

struct BagRun {
  BagFormat format;
  Compression compression;
  LidarConvention convention;
  InsMessage ins;
  const char* ins_topic;  ///< nullptr: automatic
};

std::string run_name(const BagRun& r) {
  const char* formats[] = {"ros1", "mcap", "db3"};
  return std::string(formats[static_cast<int>(r.format)]) + "_" + cli::lidar_convention_name(r.convention) + "_" +
         cli::ins_message_name(r.ins) + (r.ins_topic ? "_inspva" : "");
}

io::BagDatasets write_and_load_bag(const sim::World& world, const BagRun& run, const fs::path& dir) {
  cli::SimBagOptions o;
  o.format = run.format;
  o.compression = run.compression;
  o.lidar_convention = run.convention;
  o.ins_message = run.ins;
  const cli::SimBagResult written = cli::write_sim_bag(world, o, dir);
  EXPECT_EQ(written.frames, world.frame_count());
  io::BagOptions b;
  b.path = written.bag;
  if (run.ins_topic) b.ins_topic = run.ins_topic;
  b.init = dir / "init-extrinsic.json";
  b.fiducials = dir / "fiducials.txt";
  return io::load_bag(b);
}

void expect_same_sweeps(const Dataset& pcd, const Dataset& bag, bool bag_has_time) {
  ASSERT_EQ(pcd.frames.frames.size(), bag.frames.frames.size());
  for (std::size_t k = 0; k < pcd.frames.frames.size(); ++k) {
    SCOPED_TRACE(k);
    EXPECT_NEAR(pcd.frames.frames[k].t_end_s, bag.frames.frames[k].t_end_s, 1e-6);
    const Sweep a = pcd.frames.load(k), b = bag.frames.load(k);
    ASSERT_EQ(a.size(), b.size());
    EXPECT_NEAR(a.t_end_s, b.t_end_s, 1e-6);
    ASSERT_EQ(b.has_time(), bag_has_time);
    double worst_p = 0.0, worst_t = 0.0;
    for (std::size_t i = 0; i < a.size(); ++i) {
      worst_p = std::max(worst_p, (a.p_lidar[i] - b.p_lidar[i]).cast<double>().norm());
      if (bag_has_time) {
        worst_t = std::max(worst_t, std::abs((a.t_end_s + a.dt_s[i]) - (b.t_end_s + b.dt_s[i])));
      }
    }
    EXPECT_LE(worst_p, 1e-6);
    EXPECT_LE(worst_t, 1e-6);
  }
}

// T_world_ins of the bag is T_world_simins * T_simins_ins: compare in the simulator's frame, sample
// by sample (interpolating at a time would add the double's 2.4e-7 s resolution at 1.7e9 s).
void expect_same_poses(const Dataset& pcd, const Dataset& bag, const Iso3& T_sim_msg) {
  const auto& a = pcd.poses.poses();
  const auto& b = bag.poses.poses();
  ASSERT_EQ(a.size(), b.size());
  double worst_t = 0.0, worst_p = 0.0, worst_R = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    const Iso3 T = b[i].T_world_ins * T_sim_msg.inverse();
    worst_t = std::max(worst_t, std::abs(a[i].t_s - b[i].t_s));
    worst_p = std::max(worst_p, (T.translation() - a[i].T_world_ins.translation()).norm());
    worst_R = std::max(worst_R, (T.linear() - a[i].T_world_ins.linear()).norm());
  }
  EXPECT_LE(worst_t, 1e-6);
  EXPECT_LE(worst_p, 1e-6);
  EXPECT_LE(worst_R, 1e-9);
  ASSERT_EQ(pcd.fiducials.size(), bag.fiducials.size());
  for (std::size_t i = 0; i < pcd.fiducials.size(); ++i) {
    EXPECT_EQ(pcd.fiducials[i].id, bag.fiducials[i].id);
    EXPECT_LE((pcd.fiducials[i].p_world - bag.fiducials[i].p_world).norm(), 1e-6) << pcd.fiducials[i].id;
  }
  ASSERT_TRUE(bag.T_ins_lidar_init && pcd.T_ins_lidar_init);
  EXPECT_LE(((T_sim_msg * *bag.T_ins_lidar_init).matrix() - pcd.T_ins_lidar_init->matrix()).norm(), 1e-9);
}

TEST(BagEndToEnd, EveryFormatConventionAndInsMessageGivesThePcdFoldersData) {
  sim::SimConfig c;
  c.seed = 4;
  c.duration_s = 3.0;  // 30 frames
  c.azimuth_step_deg = 2.0;
  c.lidar_model = "vlp16";
  c.time_offset_s = 0.02;
  const sim::World world = sim::build_world(c);
  const testing::ScratchDir scratch = scratch_dir("sweeps");
  const fs::path dir = scratch.path();
  const Dataset pcd = write_and_load_pcd(world, dir / "pcd");
  const BagRun runs[] = {
      {BagFormat::kRos1, Compression::kLz4, LidarConvention::kHesai, InsMessage::kInspva, nullptr},
      {BagFormat::kRos1, Compression::kLz4, LidarConvention::kHesai, InsMessage::kInspva, "/novatel/oem7/inspva"},
      {BagFormat::kMcap, Compression::kZstd, LidarConvention::kVelodyne, InsMessage::kNavSatFixImu, nullptr},
      {BagFormat::kDb3, Compression::kNone, LidarConvention::kOuster, InsMessage::kOdometry, nullptr},
      {BagFormat::kMcap, Compression::kLz4, LidarConvention::kNone, InsMessage::kTf, nullptr},
      {BagFormat::kRos1, Compression::kBz2, LidarConvention::kOuster, InsMessage::kTf, nullptr},
  };
  for (const BagRun& run : runs) {
    const std::string name = run_name(run);
    SCOPED_TRACE(name);
    const io::BagDatasets bag = write_and_load_bag(world, run, dir / name);
    ASSERT_EQ(bag.lidars.size(), 1u);
    expect_same_sweeps(pcd, bag.lidars[0], run.convention != LidarConvention::kNone);
    expect_same_poses(pcd, bag.lidars[0], cli::T_sim_ins_message(world, run.ins));
    EXPECT_TRUE(bag.report.clock.consistent);
    EXPECT_NEAR(bag.report.clock.stamp_gap_s, c.time_offset_s + 0.003, 1e-3);  // the recorder's clock is the INS's
    if (run.ins == InsMessage::kInspva) {
      EXPECT_EQ(bag.report.ins.kind, run.ins_topic ? "NovAtel INSPVA" : "NovAtel INSPVAX");
      EXPECT_EQ(bag.lidars[0].ins_quality.size(), run.ins_topic ? 0u : bag.lidars[0].poses.size());
    }
  }
}

// A rig: one topic per LiDAR (named as its folder would be), each on its own clock, same poses.
TEST(BagEndToEnd, RigLidarsAreTopicsWithTheirOwnClocks) {
  sim::SimConfig c;
  c.seed = 8;
  c.duration_s = 1.5;
  c.azimuth_step_deg = 2.0;
  c.rig = "top:vlp16,left:vlp16@left";
  const sim::World world = sim::build_world(c);
  ASSERT_EQ(world.lidars.size(), 2u);
  const testing::ScratchDir scratch = scratch_dir("rig");
  const fs::path dir = scratch.path();
  cli::SimBagOptions o;
  o.format = BagFormat::kRos1;
  o.lidar_convention = LidarConvention::kOuster;
  o.ins_message = InsMessage::kOdometry;
  const cli::SimBagResult written = cli::write_sim_bag(world, o, dir);
  io::BagOptions b;
  b.path = written.bag;
  EXPECT_NE(std::string([&] {
              try {
                io::load_bag(b);
              } catch (const InputError& e) {
                return std::string(e.what());
              }
              return std::string();
            }())
                .find("candidates: /top (15 msgs), /left (15 msgs)"),
            std::string::npos);
  b.lidar_topics = {"/top", "/left"};
  const io::BagDatasets bag = io::load_bag(b);
  EXPECT_EQ(bag.lidar_names, (std::vector<std::string>{"top", "left"}));
  for (std::size_t j = 0; j < 2; ++j) {
    SCOPED_TRACE(j);
    const Dataset& d = bag.lidars[j];
    ASSERT_EQ(d.frames.frames.size(), world.lidars[j].frame_times_s.size());
    for (std::size_t k : {std::size_t{0}, d.frames.frames.size() - 1}) {
      const Sweep truth = sim::render_lidar_sweep(world, j, k), got = d.frames.load(k);
      ASSERT_EQ(truth.size(), got.size());
      EXPECT_NEAR(truth.t_end_s, got.t_end_s, 1e-6);
      EXPECT_NEAR(truth.t_end_s, d.frames.frames[k].t_end_s, 1e-6);
      for (std::size_t i = 0; i < got.size(); i += 97) EXPECT_LE((truth.p_lidar[i] - got.p_lidar[i]).norm(), 1e-6f);
    }
  }
  EXPECT_EQ(bag.lidars[0].poses.size(), bag.lidars[1].poses.size());
  const nlohmann::json gt = nlohmann::json::parse(io::read_file(dir / "ground_truth.json"));
  EXPECT_EQ(gt["lidars"]["left"]["topic"], "/left");
  EXPECT_NEAR(gt["lidars"]["left"]["time_offset_s"].get<double>(), world.lidars[1].time_offset_s, 1e-12);
  EXPECT_TRUE(fs::exists(dir / "init-extrinsic-left.json"));
}

// Calibration from the PCD folder and from recordings of the same drive: the same answer.
TEST(BagEndToEnd, CalibrationFromPcdAndFromBagAgree) {
  sim::SimConfig c;
  c.seed = 5;
  c.duration_s = 20.0;
  c.azimuth_step_deg = 1.5;
  c.time_offset_s = 0.02;
  const sim::World world = sim::build_world(c);
  const testing::ScratchDir scratch = scratch_dir("calibrate");
  const fs::path dir = scratch.path();
  const Dataset pcd = write_and_load_pcd(world, dir / "pcd");
  PipelineConfig config;
  config.repeatability.segments = 0;
  const auto t0 = std::chrono::steady_clock::now();
  const CalibrationResult from_pcd = run_calibration(make_frame_store(pcd, config), config);
  const double pcd_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const ExtrinsicError truth = extrinsic_error(from_pcd.T_ins_lidar, world.T_ins_lidar_true);
  EXPECT_LT(truth.angle_deg, 0.05);
  const BagRun runs[] = {{BagFormat::kMcap, Compression::kZstd, LidarConvention::kHesai, InsMessage::kInspva, nullptr},
                         {BagFormat::kRos1, Compression::kLz4, LidarConvention::kVelodyne, InsMessage::kNavSatFixImu, nullptr}};
  for (const BagRun& run : runs) {
    SCOPED_TRACE(run_name(run));
    const io::BagDatasets bag = write_and_load_bag(world, run, dir / run_name(run));
    // The TUM file states no INS quality; the recording does. Stages that use it must see it alike.
    ASSERT_TRUE(bag.lidars[0].ins_quality.empty() || run.ins == InsMessage::kInspva || run.ins == InsMessage::kNavSatFixImu);
    Dataset bag_data = bag.lidars[0];
    const std::vector<InsQuality> stated = bag_data.ins_quality;
    bag_data.ins_quality.clear();
    const auto t1 = std::chrono::steady_clock::now();
    const CalibrationResult from_bag = run_calibration(make_frame_store(bag_data, config), config);
    const double bag_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t1).count();
    const ExtrinsicError d = extrinsic_error(cli::T_sim_ins_message(world, run.ins) * from_bag.T_ins_lidar, from_pcd.T_ins_lidar);
    // Equal to float rounding in the messages, amplified by the data's own start (global_init):
    // a few 1e-6 deg, a thousandth of the stated stddev.
    EXPECT_LE(d.dt_m.norm(), 1e-5);
    EXPECT_LE(d.angle_deg, 1e-5);
    EXPECT_NEAR(from_bag.time_offset_s, from_pcd.time_offset_s, 1e-6);
    EXPECT_EQ(from_bag.determined, from_pcd.determined);
    EXPECT_FALSE(stated.empty());  // both recordings carry the INS's own solution status
    std::printf("%s: PCD %.2f s, bag %.2f s; bag - PCD: %.2e m, %.2e deg; PCD - truth: %.1f mm, %.4f deg\n",
                run_name(run).c_str(), pcd_s, bag_s, d.dt_m.norm(), d.angle_deg, 1e3 * truth.dt_m.norm(), truth.angle_deg);
  }
}

}  // namespace
}  // namespace insalign
