// One simulated drive written as the PCD folder with TUM poses (the OpenCalib layout) and as each
// INS log format (`insalign simulate --poses-format`, sim/export/sim_ins_export.hpp): every format reads
// back to the same sweeps and, up to its `ins` frame, the same poses and fiducials, and calibrates
// from the simulator's wrong start to the same answer. Then the clock rules on the data: an 18 s
// GPS-UTC offset is found and corrected, an unexplained gap is an InputError naming both ranges.
#include <fmt/format.h>
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "sim/export/sim_ins_export.hpp"
#include "ins_log_test_util.hpp"
#include "cli_test_util.hpp"
#include "core/errors.hpp"
#include "core/pipeline.hpp"
#include "files/fiducials.hpp"
#include "input/input_source.hpp"
#include "pointcloud/pcd.hpp"
#include "files/atomic_file.hpp"
#include "files/extrinsic_json.hpp"
#include "inslog/gps_time.hpp"
#include "inslog/novatel_ascii.hpp"
#include "inslog/pose_source.hpp"
#include "files/poses.hpp"
#include "files/read_file.hpp"
#include "sim/simulate.hpp"

namespace insalign {
namespace {

namespace fs = std::filesystem;
using cli::PosesFormat;

testing::ScratchDir scratch_dir(const std::string& tag) { return {"insalign_ins_e2e_", tag}; }

// The PCD folder as cmd_simulate writes it, with the 100 Hz TUM poses (the simulator's INS frame).
void write_pcd_folder(const sim::World& world, const fs::path& dir) {
  fs::create_directories(dir / "lidar");
  for (std::size_t k = 0; k < world.frame_count(); ++k) {
    const Sweep s = sim::render_sweep(world, k);
    io::write_pcd(dir / "lidar" / (s.name + ".pcd"), s, io::PcdEncoding::kBinary, io::PcdTimeField::kAbsolute);
  }
  io::write_tum_poses(dir / "poses_tum.txt", sim::dense_reported_poses(world, 100.0));
  io::write_opencalib_extrinsic(dir / "init-extrinsic.json", world.T_ins_lidar_init);
  io::write_fiducials(dir / "fiducials.txt", world.fiducials);
}

io::InputSpec pcd_spec(const fs::path& dir, const fs::path& poses) {
  io::InputSpec spec;
  spec.lidar_dirs = {dir / "lidar"};
  spec.poses = poses;
  spec.inits = {dir / "init-extrinsic.json"};
  spec.fiducials = dir / "fiducials.txt";
  return spec;
}

// A format's files, written the way `insalign simulate --poses-format` writes them, and the input
// that reads them (the shared PCD folder for the logs; the drive itself for KITTI).
struct Written {
  cli::SimInsResult result;
  io::InputSpec spec;
  io::InputConfig config;
};

Written write_format(const sim::World& world, PosesFormat format, const fs::path& pcd_dir, const fs::path& dir,
                     double ins_clock_offset_s = 0.0) {
  cli::SimInsOptions o;
  o.format = format;
  o.ins_clock_offset_s = ins_clock_offset_s;
  Written w;
  if (format == PosesFormat::kKitti) {
    w.result = cli::write_sim_kitti_raw(world, o, dir);
    w.spec.kitti_raw = w.result.poses;
  } else {
    w.result = cli::write_sim_ins_log(world, o, dir);
    w.spec = pcd_spec(pcd_dir, w.result.poses);
    w.spec.inits = {dir / "init-extrinsic.json"};
  }
  w.spec.fiducials = dir / "fiducials.txt";
  if (format == PosesFormat::kCsv) {  // the mapping as the user finds it: in poses-columns.txt
    std::string columns = io::read_file(dir / "poses-columns.txt");
    while (!columns.empty() && (columns.back() == '\n' || columns.back() == '\r')) columns.pop_back();
    w.config.poses_columns = columns;
  }
  return w;
}

struct CliRun {
  int rc = -1;
  std::string output;  ///< stdout and stderr
};

CliRun run_cli(const std::string& args) {
  const auto [rc, output] = testing::run_command(std::string(INSALIGN_EXE) + " " + args);
  return {rc, output};
}

// The command line options that name `spec`'s input, as a user types them.
std::string input_args(const io::InputSpec& spec, const io::InputConfig& config) {
  std::string a;
  for (const fs::path& d : spec.lidar_dirs) a += " --lidar-dir " + d.string();
  if (!spec.poses.empty()) a += " --poses " + spec.poses.string();
  if (!spec.kitti_raw.empty()) a += " --kitti-raw " + spec.kitti_raw.string();
  for (const fs::path& i : spec.inits) a += " --init " + i.string();
  if (spec.fiducials) a += " --fiducials " + spec.fiducials->string();
  if (!config.poses_columns.empty()) a += " --poses-columns '" + config.poses_columns + "'";
  return a;
}

struct Calibrated {
  CliRun run;
  io::ExtrinsicFile result;
  double wall_s = 0.0;
};

// `insalign calibrate` from the simulator's wrong start (its init-extrinsic.json), without the
// repeatability segments and the report (they do not change the answer).
Calibrated calibrate_cli(const io::InputSpec& spec, const io::InputConfig& config, const fs::path& out) {
  Calibrated c;
  const auto t0 = std::chrono::steady_clock::now();
  c.run = run_cli("calibrate --quiet --segments 0 --no-report" + input_args(spec, config) + " --out " + out.string());
  c.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (c.run.rc == 0) c.result = io::read_extrinsic_file(out / "extrinsic.json");
  return c;
}

struct Shared {
  testing::ScratchDir scratch = scratch_dir("calibrate");  // removed at the process's exit
  sim::World world;
  fs::path dir = scratch.path();
  io::LoadedInput pcd;
  Calibrated opencalib;
};

// One 20 s drive at a sixth of the full resolution for every calibration in this file.
const Shared& calibration_drive() {
  static const std::unique_ptr<Shared> shared = [] {
    auto s = std::make_unique<Shared>();
    sim::SimConfig c;
    c.seed = 5;
    c.duration_s = 20.0;
    c.lidar_model = "vlp16";
    c.azimuth_step_deg = 1.0;
    c.time_offset_s = 0.02;
    s->world = sim::build_world(c);
    write_pcd_folder(s->world, s->dir / "pcd");
    const io::InputSpec spec = pcd_spec(s->dir / "pcd", s->dir / "pcd" / "poses_tum.txt");
    s->pcd = io::load_input(spec);
    s->opencalib = calibrate_cli(spec, {}, s->dir / "out_opencalib");
    return s;
  }();
  return *shared;
}

// T_world_ins of the log is T_world_simins * T_simins_ins: compare in the simulator's frame, sample by
// sample, to what the logs print (0.1 mm heights, 1e-11 deg positions, 1e-9 deg or 1e-6 rad angles).
void expect_same_poses(const Dataset& pcd, const Dataset& log, const Iso3& T_sim_ins) {
  const auto& a = pcd.poses.poses();
  const auto& b = log.poses.poses();
  ASSERT_EQ(a.size(), b.size());
  double worst_t = 0.0, worst_p = 0.0, worst_R = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    const Iso3 T = b[i].T_world_ins * T_sim_ins.inverse();
    worst_t = std::max(worst_t, std::abs(a[i].t_s - b[i].t_s));
    worst_p = std::max(worst_p, (T.translation() - a[i].T_world_ins.translation()).norm());
    worst_R = std::max(worst_R, Eigen::AngleAxisd(T.linear() * a[i].T_world_ins.linear().transpose()).angle() * kDegPerRad);
  }
  EXPECT_LE(worst_t, 2e-6);  // KITTI's timestamps: nanoseconds printed from a double near 1.7e9
  EXPECT_LE(worst_p, 2e-4);
  EXPECT_LE(worst_R, 1e-4);
  ASSERT_EQ(pcd.fiducials.size(), log.fiducials.size());
  for (std::size_t i = 0; i < pcd.fiducials.size(); ++i) {
    EXPECT_EQ(pcd.fiducials[i].id, log.fiducials[i].id);
    EXPECT_LE((pcd.fiducials[i].p_world - log.fiducials[i].p_world).norm(), 2e-4) << pcd.fiducials[i].id;
  }
  ASSERT_TRUE(log.T_ins_lidar_init && pcd.T_ins_lidar_init);
  EXPECT_LE(((T_sim_ins * *log.T_ins_lidar_init).matrix() - pcd.T_ins_lidar_init->matrix()).norm(), 1e-9);
}

// KITTI's frame time is timestamps_end.txt, the end of the full turn: up to one column after the
// last point (the PCD folder's frame time).
void expect_same_sweeps(const Dataset& pcd, const Dataset& log, double frame_time_tolerance_s) {
  ASSERT_EQ(pcd.frames.frames.size(), log.frames.frames.size());
  for (std::size_t k : {std::size_t{0}, pcd.frames.frames.size() / 2, pcd.frames.frames.size() - 1}) {
    SCOPED_TRACE(k);
    EXPECT_NEAR(pcd.frames.frames[k].t_end_s, log.frames.frames[k].t_end_s, frame_time_tolerance_s);
    const Sweep a = pcd.frames.load(k), b = log.frames.load(k);
    ASSERT_EQ(a.size(), b.size());
    double worst_p = 0.0, worst_t = 0.0;
    for (std::size_t i = 0; i < a.size(); ++i) {
      worst_p = std::max(worst_p, static_cast<double>((a.p_lidar[i] - b.p_lidar[i]).norm()));
      worst_t = std::max(worst_t, std::abs((a.t_end_s + a.dt_s[i]) - (b.t_end_s + b.dt_s[i])));
    }
    EXPECT_LE(worst_p, 1e-6);
    EXPECT_LE(worst_t, 1e-5);  // KITTI: from the azimuth
  }
}

class InsFormatsEndToEnd : public ::testing::TestWithParam<PosesFormat> {};

TEST_P(InsFormatsEndToEnd, ReadsBackAndCalibratesAsTheOpenCalibLayout) {
  const Shared& s = calibration_drive();
  const PosesFormat format = GetParam();
  const Written w = write_format(s.world, format, s.dir / "pcd", s.dir / cli::poses_format_name(format));
  const io::LoadedInput in = io::load_input(w.spec, w.config);
  ASSERT_EQ(in.lidars.size(), 1u);
  const io::LoadReport& report = in.reports[0];
  EXPECT_EQ(report.ins.kind, cli::poses_format_name(format));
  EXPECT_FALSE(report.ins.body_frame.empty());
  EXPECT_FALSE(report.ins.height_datum.empty());
  EXPECT_FALSE(report.ins.time_base.empty());
  ASSERT_TRUE(report.ins.enu_origin);
  EXPECT_NEAR(report.ins.enu_origin->lat_deg, 48.137154, 1e-9);
  ASSERT_TRUE(report.clock);
  EXPECT_EQ(report.clock->offset_s, 0.0);
  const Iso3 T_sim_ins = cli::T_sim_ins_format(s.world, format);
  expect_same_poses(s.pcd.lidars[0], in.lidars[0], T_sim_ins);
  const bool kitti = format == PosesFormat::kKitti;
  const double column_s = s.world.config.azimuth_step_deg / 360.0 / s.world.config.frame_rate_hz;
  expect_same_sweeps(s.pcd.lidars[0], in.lidars[0], kitti ? column_s : 2e-6);

  // The TUM file states no INS quality; the logs do (SBET none).
  EXPECT_EQ(in.lidars[0].ins_quality.empty(), format == PosesFormat::kSbet);

  ASSERT_EQ(s.opencalib.run.rc, 0) << s.opencalib.run.output;
  const Calibrated c = calibrate_cli(w.spec, w.config, s.dir / ("out_" + std::string(cli::poses_format_name(format))));
  ASSERT_EQ(c.run.rc, 0) << c.run.output;
  // Against the truth in the format's own ins frame (ground_truth.json's T_ins_lidar) ...
  const nlohmann::json gt = nlohmann::json::parse(io::read_file(w.spec.fiducials->parent_path() / "ground_truth.json"));
  const Iso3 T_truth = io::transform_from_json(gt["T_ins_lidar"], "ground_truth.json");
  EXPECT_LT((T_truth.matrix() - w.result.T_ins_lidar.matrix()).norm(), 1e-9);
  EXPECT_LT((T_truth.matrix() - (T_sim_ins.inverse() * s.world.T_ins_lidar_true).matrix()).norm(), 1e-9);
  const ExtrinsicError truth = extrinsic_error(c.result.T_ins_lidar, T_truth);
  const ExtrinsicError opencalib_truth = extrinsic_error(s.opencalib.result.T_ins_lidar, s.world.T_ins_lidar_true);
  EXPECT_LT(truth.angle_deg, std::max(0.05, 1.2 * opencalib_truth.angle_deg));
  EXPECT_LT(truth.dt_norm_m, std::max(0.03, 1.2 * opencalib_truth.dt_norm_m));
  // ... and against the OpenCalib layout's answer: the same up to the logs' printed precision (KITTI:
  // point times from the azimuth, float seconds, the frame time at the turn's end).
  const ExtrinsicError d = extrinsic_error(T_sim_ins * c.result.T_ins_lidar, s.opencalib.result.T_ins_lidar);
  EXPECT_LE(d.dt_norm_m, kitti ? 1e-3 : 2e-4);
  EXPECT_LE(d.angle_deg, kitti ? 5e-3 : 2e-4);
  ASSERT_TRUE(c.result.time_offset_s && s.opencalib.result.time_offset_s);
  EXPECT_NEAR(*c.result.time_offset_s, *s.opencalib.result.time_offset_s, 1e-3);
  std::printf("%s: %.1f s (OpenCalib %.1f s); vs OpenCalib layout %.2e m, %.2e deg; vs truth %.1f mm, %.4f deg (OpenCalib %.1f mm, "
              "%.4f deg)\n",
              cli::poses_format_name(format), c.wall_s, s.opencalib.wall_s, d.dt_norm_m, d.angle_deg, 1e3 * truth.dt_norm_m,
              truth.angle_deg, 1e3 * opencalib_truth.dt_norm_m, opencalib_truth.angle_deg);
}

INSTANTIATE_TEST_SUITE_P(Formats, InsFormatsEndToEnd,
                         ::testing::Values(PosesFormat::kNovatel, PosesFormat::kSbet, PosesFormat::kCsv, PosesFormat::kKitti),
                         [](const auto& info) { return std::string(cli::poses_format_name(info.param)); });

// A 45 s drive for the clock rules: long enough that an 18 s shift still leaves most frames inside
// the INS range, so that the ranges alone cannot tell and the motion must.
struct ClockDrive {
  testing::ScratchDir scratch = scratch_dir("clock");  // removed at the process's exit
  sim::World world;
  fs::path dir = scratch.path();
};

const ClockDrive& clock_drive() {
  static const std::unique_ptr<ClockDrive> shared = [] {
    auto s = std::make_unique<ClockDrive>();
    sim::SimConfig c;
    c.seed = 7;
    c.duration_s = 45.0;
    c.lidar_model = "vlp16";
    c.azimuth_step_deg = 2.0;
    s->world = sim::build_world(c);
    write_pcd_folder(s->world, s->dir / "pcd");
    return s;
  }();
  return *shared;
}

TEST(InsFormatsClock, GpsMinusUtcIsFoundFromTheDataCorrectedAndReported) {
  const ClockDrive& s = clock_drive();
  const io::LoadedInput truth = io::load_input(pcd_spec(s.dir / "pcd", s.dir / "pcd" / "poses_tum.txt"));
  for (const PosesFormat format : {PosesFormat::kNovatel, PosesFormat::kSbet, PosesFormat::kCsv}) {
    SCOPED_TRACE(cli::poses_format_name(format));
    const Written w = write_format(s.world, format, s.dir / "pcd", s.dir / (std::string("gps18_") + cli::poses_format_name(format)), 18.0);
    const io::LoadedInput in = io::load_input(w.spec, w.config);
    const io::LoadReport& r = in.reports[0];
    ASSERT_TRUE(r.clock);
    EXPECT_EQ(r.clock->offset_s, 18.0);
    EXPECT_TRUE(r.clock->checked_by_data);
    EXPECT_NE(r.clock->meaning.find("GPS"), std::string::npos) << r.clock->meaning;
    EXPECT_NE(r.clock->summary.find("18"), std::string::npos) << r.clock->summary;
    EXPECT_FALSE(r.clock->evidence.empty());
    // Corrected: the poses on the LiDAR clock, as the PCD folder's TUM poses are.
    expect_same_poses(truth.lidars[0], in.lidars[0], cli::T_sim_ins_format(s.world, format));
    EXPECT_EQ(in.lidars[0].frames.frames.size(), truth.lidars[0].frames.frames.size());
  }
}

std::string load_error(const Written& w) {
  try {
    io::load_input(w.spec, w.config);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(InsFormatsClock, AnUnexplainedGapIsAnInputErrorNamingBothRanges) {
  const ClockDrive& s = clock_drive();
  for (const double gap_s : {500.0, 7.0}) {
    SCOPED_TRACE(gap_s);
    const Written w = write_format(s.world, PosesFormat::kNovatel, s.dir / "pcd",
                                   s.dir / ("gap" + std::to_string(static_cast<int>(gap_s))), gap_s);
    const std::string what = load_error(w);
    ASSERT_FALSE(what.empty()) << "a " << gap_s << " s gap was accepted";
    EXPECT_NE(what.find(w.result.poses.string()), std::string::npos) << what;
    // Both ranges, as the frames and the log state them (the LiDAR's first frame, the INS's first record).
    const double lidar_begin = s.world.frame_times_s.front(), ins_begin = sim::dense_reported_poses(s.world).front().t_s + gap_s;
    EXPECT_NE(what.find(std::to_string(static_cast<long long>(lidar_begin))), std::string::npos) << what;
    EXPECT_NE(what.find(std::to_string(static_cast<long long>(ins_begin))), std::string::npos) << what;
  }
}

// The attitude conventions end to end: a vehicle driving north, east, south and west, each log
// written by hand in its own convention (not by inslog/ins_log_writer), read through --poses'
// reader. The axis that the format calls forward must point along the travelled path, and its
// vertical axis up (or down for the z-down frames).
struct Heading {
  const char* name;
  double cw_from_north_deg;
  Vec3 forward_enu;
};
const Heading kHeadings[] = {{"north", 0.0, {0, 1, 0}}, {"east", 90.0, {1, 0, 0}}, {"south", 180.0, {0, -1, 0}},
                             {"west", 270.0, {-1, 0, 0}}};

constexpr double kT0 = 1700000000.0, kLat0 = 48.1, kLon0 = 11.5, kH0 = 500.0;
constexpr int kRecords = 20;  // 10 Hz, 1 m apart

// Position of record i: 1 m per record along the heading (metres per degree of the WGS-84
// ellipsoid at kLat0, the usual series: good to a centimetre over this drive).
std::pair<double, double> lat_lon_at(const Heading& h, int i) {
  const double phi = kLat0 * M_PI / 180.0;
  const double m_per_deg_lat = 111132.92 - 559.82 * std::cos(2 * phi) + 1.175 * std::cos(4 * phi);
  const double m_per_deg_lon = 111412.84 * std::cos(phi) - 93.5 * std::cos(3 * phi);
  return {kLat0 + i * h.forward_enu.y() / m_per_deg_lat, kLon0 + i * h.forward_enu.x() / m_per_deg_lon};
}

void write_heading_log(PosesFormat format, const Heading& h, const fs::path& path) {
  std::string text;
  if (format == PosesFormat::kCsv) text = "time,lat,lon,h,roll,pitch,heading\n";
  if (format == PosesFormat::kKitti) fs::create_directories(path / "data");
  for (int i = 0; i < kRecords; ++i) {
    const auto [lat, lon] = lat_lon_at(h, i);
    const double t = kT0 + 0.1 * i;
    const double gps = t - 315964800.0 + 18.0;  // GPS time (18 leap seconds in 2023)
    const int week = static_cast<int>(gps / 604800.0);
    const double sow = gps - week * 604800.0;
    if (format == PosesFormat::kNovatel) {  // SPAN azimuth, clockwise from north
      text += test::novatel_record_line(
          '#', fmt::format("INSPVAA,COM1,0,50.0,FINESTEERING,{},{:.3f},02000020,18bc,16809;{},{:.9f},{:.11f},{:.11f},{:.4f},"
                           "0.0,0.0,0.0,0.000000000,0.000000000,{:.9f},INS_SOLUTION_GOOD",
                           week, sow, week, sow, lat, lon, kH0, h.cw_from_north_deg));
    } else if (format == PosesFormat::kSbet) {  // 17 float64, radians, wander 0
      const double r[17] = {sow, lat * M_PI / 180.0, lon * M_PI / 180.0, kH0, 0, 0, 0, 0, 0, h.cw_from_north_deg * M_PI / 180.0, 0,
                            0,   0,                  0,                  0,   0, 0};
      text.append(reinterpret_cast<const char*>(r), sizeof r);
    } else if (format == PosesFormat::kCsv) {  // aerospace heading, clockwise from north
      text += fmt::format("{:.3f},{:.11f},{:.11f},{:.4f},0,0,{:.6f}\n", t, lat, lon, kH0, h.cw_from_north_deg);
    } else {  // OXTS: yaw counter-clockwise from east, radians
      const double yaw = (90.0 - h.cw_from_north_deg) * M_PI / 180.0;
      test::write_text(path / "data" / fmt::format("{:010}.txt", i),
                       fmt::format("{:.12f} {:.12f} {:.4f} 0 0 {:.9f} 0 0 0 0 0 0 0 9.81 0 0 9.81 0 0 0 0 0 0 0.02 0.01 4 10 6 6 6\n",
                                   lat, lon, kH0, yaw));
      text += io::format_utc(t) + "\n";
    }
  }
  io::write_file_atomic(format == PosesFormat::kKitti ? path / "timestamps.txt" : path, text);
}

TEST(InsFormatsHeading, EachFormatsForwardAxisPointsAlongTheDriveNorthEastSouthWest) {
  const testing::ScratchDir scratch = scratch_dir("heading");
  const fs::path dir = scratch.path();
  for (const PosesFormat format : {PosesFormat::kNovatel, PosesFormat::kSbet, PosesFormat::kCsv, PosesFormat::kKitti}) {
    // Forward and up axes of the format's ins frame (CONVENTIONS.md): column index and sign.
    const int forward_axis = format == PosesFormat::kNovatel ? 1 : 0;
    const double up_sign = format == PosesFormat::kSbet || format == PosesFormat::kCsv ? -1.0 : 1.0;
    for (const Heading& h : kHeadings) {
      SCOPED_TRACE(std::string(cli::poses_format_name(format)) + " " + h.name);
      const fs::path path = dir / (std::string(cli::poses_format_name(format)) + "_" + h.name +
                                   (format == PosesFormat::kSbet ? ".out" : format == PosesFormat::kKitti ? "" : ".txt"));
      write_heading_log(format, h, path);
      io::PoseSourceOptions options;
      options.lidar_time_hint_unix_s = kT0;
      if (format == PosesFormat::kCsv) {
        options.columns_spec = "time=time:unix,lat=lat,lon=lon,height=h,roll=roll,pitch=pitch,heading=heading:cw-from-north,"
                               "units=deg,frame=x-forward-y-right-z-down";
      }
      const io::PoseSource source = io::read_pose_source(path, options);
      EXPECT_EQ(source.facts.kind, cli::poses_format_name(format));
      ASSERT_EQ(source.poses.size(), static_cast<std::size_t>(kRecords));
      const Vec3 travel = source.poses.back().T_world_ins.translation() - source.poses.front().T_world_ins.translation();
      EXPECT_NEAR(travel.norm(), kRecords - 1.0, 0.01);
      EXPECT_LT((travel.normalized() - h.forward_enu).norm(), 1e-3);
      for (const io::SourcePose& p : source.poses) {
        EXPECT_LT((p.T_world_ins.linear().col(forward_axis) - h.forward_enu).norm(), 1e-4);
        EXPECT_LT((p.T_world_ins.linear().col(2) - up_sign * Vec3::UnitZ()).norm(), 1e-4);
      }
    }
  }
}

// The command line as users call it: simulate writes the log, calibrate reads it (once helper
// A's --poses wiring is in: it already reads any --poses file through load_input).
TEST(InsFormatsCli, SimulateWritesEachFormatWithItsSideFiles) {
  const testing::ScratchDir scratch = scratch_dir("cli");
  const fs::path dir = scratch.path();
  for (const char* format : {"novatel", "sbet", "csv", "kitti", "tum"}) {
    SCOPED_TRACE(format);
    const fs::path out = dir / format;
    const std::string cmd = std::string(INSALIGN_EXE) + " simulate --quiet --lidar vlp16 --azimuth-step-deg 4 --duration-s 1 --out " +
                            out.string() + " --poses-format " + format + " > /dev/null";
    ASSERT_EQ(WEXITSTATUS(std::system(cmd.c_str())), 0);
    const nlohmann::json gt = nlohmann::json::parse(io::read_file(out / "ground_truth.json"));
    EXPECT_TRUE(gt.contains("T_ins_lidar"));
    if (std::string(format) == "tum") {
      EXPECT_TRUE(fs::exists(out / "poses_tum.txt"));
      continue;
    }
    EXPECT_EQ(gt["ins_log"]["format"], format);
    EXPECT_TRUE(fs::exists(out / gt["ins_log"]["path"].get<std::string>()));
    EXPECT_EQ(io::read_file(out / "fiducials.txt").rfind("# wgs84", 0), 0u);
  }
  EXPECT_TRUE(fs::exists(dir / "kitti" / "calib_imu_to_velo.txt"));
  EXPECT_TRUE(fs::exists(dir / "csv" / "poses-columns.txt"));
  // Bad combinations are usage errors.
  const std::string bad = std::string(INSALIGN_EXE) + " simulate --quiet --duration-s 1 --out " + (dir / "bad").string() +
                          " --poses-format kitti --ins-clock-offset-s 18 2> /dev/null";
  EXPECT_EQ(WEXITSTATUS(std::system(bad.c_str())), 2);
  const std::string half = std::string(INSALIGN_EXE) + " simulate --quiet --duration-s 1 --out " + (dir / "bad").string() +
                           " --poses-format novatel --ins-clock-offset-s 0.5 2> /dev/null";
  EXPECT_EQ(WEXITSTATUS(std::system(half.c_str())), 2);
}

// Issue 16's bad inputs through the command line: exit 2, the message naming the file and the line
// or byte. The logs are the simulator's, corrupted the way a cut transfer or a buggy exporter would.
std::vector<std::string> lines_of(const std::string& text) {
  std::vector<std::string> lines;
  std::size_t begin = 0;
  for (std::size_t end; (end = text.find('\n', begin)) != std::string::npos; begin = end + 1) lines.push_back(text.substr(begin, end + 1 - begin));
  return lines;
}

std::string joined(const std::vector<std::string>& lines) {
  std::string s;
  for (const std::string& l : lines) s += l;
  return s;
}

// A NovAtel record with one field replaced and its CRC made right again (only the field is wrong).
std::string novatel_with_field(const std::string& record, int field, const std::string& value) {
  const std::size_t star = record.find('*');
  std::string content = record.substr(1, star - 1);
  const std::size_t body = content.find(';') + 1;
  std::size_t begin = body;
  for (int i = 0; i < field; ++i) begin = content.find(',', begin) + 1;
  const std::size_t end = content.find(',', begin);
  content.replace(begin, end - begin, value);
  return record.substr(0, 1) + content + fmt::format("*{:08x}\r\n", io::novatel_crc32(content));
}

TEST(InsFormatsCli, BadLogsExit2NamingTheFileAndTheLineOrByte) {
  sim::SimConfig c;
  c.duration_s = 1.0;
  c.lidar_model = "vlp16";
  c.azimuth_step_deg = 4.0;
  const sim::World world = sim::build_world(c);
  const testing::ScratchDir scratch = scratch_dir("bad");
  const fs::path dir = scratch.path();
  write_pcd_folder(world, dir / "pcd");
  cli::SimInsOptions o;
  o.format = PosesFormat::kNovatel;
  const std::vector<std::string> log = lines_of(io::read_file(cli::write_sim_ins_log(world, o, dir / "novatel").poses));
  o.format = PosesFormat::kSbet;
  const std::string sbet = io::read_file(cli::write_sim_ins_log(world, o, dir / "sbet").poses);
  o.format = PosesFormat::kCsv;
  const std::vector<std::string> csv = lines_of(io::read_file(cli::write_sim_ins_log(world, o, dir / "csv").poses));
  ASSERT_GT(log.size(), 50u);

  struct Case {
    std::string name, content, where, what;
  };
  std::vector<Case> cases;
  std::vector<std::string> l = log;
  l[10] = novatel_with_field(l[10], 2, "91.00000000000");  // latitude
  cases.push_back({"lat91.log", joined(l), "line 11", "latitude"});
  l = log;
  l[20] = novatel_with_field(l[20], 9, "nan");  // roll
  cases.push_back({"nan.log", joined(l), "line 21", "roll"});
  l = log;
  std::swap(l[30], l[31]);
  cases.push_back({"backwards.log", joined(l), "line 32", "time goes backwards"});
  l = log;
  for (std::size_t i = 1; i < l.size(); i += 2) l[i][l[i].find('*') + 3] ^= 1;  // every other CRC wrong
  cases.push_back({"crc.log", joined(l), "", "CRC"});
  cases.push_back({"cut.out", sbet.substr(0, 136 * 40 + 50), "byte 5440", "not a multiple of 136"});
  std::vector<std::string> k = csv;
  k[5].replace(0, k[5].find(','), "2288,");  // week only: the row is short a field
  cases.push_back({"short.csv", joined(k), "line 6", "fields"});
  for (const Case& bad : cases) {
    SCOPED_TRACE(bad.name);
    const fs::path path = dir / bad.name;
    io::write_file_atomic(path, bad.content);
    std::string args = "info --lidar-dir " + (dir / "pcd" / "lidar").string() + " --poses " + path.string();
    if (bad.name.ends_with(".csv")) args += " --poses-columns '" + std::string(io::kTextExportWriterSpec) + "'";
    const CliRun r = run_cli(args);
    EXPECT_EQ(r.rc, 2) << r.output;
    EXPECT_NE(r.output.find(path.string() + (bad.where.empty() ? "" : ":" + bad.where)), std::string::npos) << r.output;
    EXPECT_NE(r.output.find(bad.what), std::string::npos) << r.output;
  }
  // A cut-short last record is an interrupted write: skipped and counted, not an error.
  const fs::path cut = dir / "cut.log";
  io::write_file_atomic(cut, joined(log).substr(0, joined(log).size() - 40));
  const CliRun r = run_cli("info --lidar-dir " + (dir / "pcd" / "lidar").string() + " --poses " + cut.string());
  EXPECT_EQ(r.rc, 0) << r.output;
  EXPECT_NE(r.output.find("(1 skipped)"), std::string::npos) << r.output;
}

// simulate --config: the sim section of a tool config, the options given beside it winning.
TEST(InsFormatsCli, SimulateConfigFileSetsTheSimSectionAndOptionsOverrideIt) {
  const testing::ScratchDir scratch = scratch_dir("config");
  const fs::path dir = scratch.path();
  {
    std::FILE* f = std::fopen((dir / "sim.yaml").c_str(), "w");
    std::fputs("sim:\n  seed: 9\n  lidar_model: vlp16\n  azimuth_step_deg: 4.0\n  duration_s: 1.0\n  n_fiducials: 3\n", f);
    std::fclose(f);
  }
  const std::string base = std::string(INSALIGN_EXE) + " simulate --quiet --config " + (dir / "sim.yaml").string();
  ASSERT_EQ(WEXITSTATUS(std::system((base + " --out " + (dir / "a").string() + " > /dev/null").c_str())), 0);
  const nlohmann::json a = nlohmann::json::parse(io::read_file(dir / "a" / "ground_truth.json"));
  EXPECT_EQ(a["config"]["seed"], 9);
  EXPECT_EQ(a["config"]["lidar_model"], "vlp16");
  EXPECT_EQ(a["config"]["n_fiducials"], 3);
  EXPECT_EQ(a["frames"], 10);
  ASSERT_EQ(WEXITSTATUS(std::system((base + " --seed 11 --scene feature-poor --out " + (dir / "b").string() + " > /dev/null").c_str())), 0);
  const nlohmann::json b = nlohmann::json::parse(io::read_file(dir / "b" / "ground_truth.json"));
  EXPECT_EQ(b["config"]["seed"], 11);
  EXPECT_EQ(b["config"]["scene"], "feature-poor");
  EXPECT_EQ(b["config"]["lidar_model"], "vlp16");
  std::FILE* f = std::fopen((dir / "bad.yaml").c_str(), "w");
  std::fputs("sim:\n  sede: 9\n", f);
  std::fclose(f);
  const std::string bad = std::string(INSALIGN_EXE) + " simulate --quiet --config " + (dir / "bad.yaml").string() + " --out " +
                          (dir / "c").string() + " 2> " + (dir / "err.txt").string();
  EXPECT_EQ(WEXITSTATUS(std::system(bad.c_str())), 2);
  EXPECT_NE(io::read_file(dir / "err.txt").find("sede"), std::string::npos);
}

}  // namespace
}  // namespace insalign
