// insalign simulate: render a synthetic calibration drive with ground truth into a dataset in the
// OpenCalib layout (CONVENTIONS.md), frame by frame so memory stays bounded.
#include <fmt/core.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <sstream>

#include "cli/commands.hpp"
#include "cli/progress.hpp"
#include "core/errors.hpp"
#include "files/poses.hpp"
#include "sim/export/ground_truth.hpp"
#include "sim/export/pcd_dataset.hpp"
#include "sim/export/sim_bag_export.hpp"
#include "sim/export/sim_ins_export.hpp"
#include "sim/simulate.hpp"
#include "sim/traffic.hpp"
#include "tool/tool_config.hpp"

namespace insalign::cli {
namespace {

namespace fs = std::filesystem;

struct SimulateOptions {
  std::string out;
  std::string scene = "intersection";
  std::string trajectory = "figure8";
  std::string ins_axes = "x-forward";
  std::string ins_error = "rtk-fixed";
  double ins_drift_m_per_sqrt_s = -1.0;  ///< < 0: the model's default
  std::string extrinsic;
  std::string knock;  ///< --knock "dx dy dz droll dpitch dyaw"
  std::string pcd_encoding = "binary_compressed";
  std::string format = "opencalib", lidar_convention = "hesai", ins_message = "inspva";  ///< sim_bag_export.hpp
  std::string bag_compression = "default", bag_chunking = "insalign";  ///< sim_bag_export.hpp
  std::size_t bag_chunk_kib = 768;
  std::string poses_format = "opencalib";  ///< sim_ins_export.hpp
  std::string novatel_record = "inspvaxa";
  double ins_clock_offset_s = 0.0;
  std::string config_file;   ///< --config: the sim section of a tool config, under the options given
  std::string config_error;  ///< why --config could not be read (reported by run_simulate)
  const CLI::App* app = nullptr;  ///< to ask which options were given
  int frames = 0;
  bool overwrite = false;
  bool quiet = false;
  sim::SimConfig config;
};

/// Thrown for option values CLI11 cannot check on its own; reported with exit code 2.
struct UsageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

Iso3 parse_extrinsic(const std::string& text) {
  std::istringstream in(text);
  double v[6];
  for (double& x : v) {
    if (!(in >> x) || !std::isfinite(x))
      throw UsageError("--extrinsic needs six numbers \"x y z roll pitch yaw\" (m, deg), got \"" + text + "\"");
  }
  std::string rest;
  if (in >> rest) throw UsageError("--extrinsic needs exactly six numbers, got \"" + text + "\"");
  return make_transform(Vec3(v[0], v[1], v[2]), Vec3(v[3], v[4], v[5]));
}

Vec6 parse_knock(const std::string& text) {
  std::istringstream in(text);
  Vec6 v;
  for (int i = 0; i < 6; ++i) {
    if (!(in >> v(i)) || !std::isfinite(v(i)))
      throw UsageError("--knock needs six numbers \"dx dy dz droll dpitch dyaw\" (m, deg), got \"" + text + "\"");
  }
  std::string rest;
  if (in >> rest) throw UsageError("--knock needs exactly six numbers, got \"" + text + "\"");
  return v;
}

// Whether an option was on the command line (with --config, the file's value stands otherwise).
bool given(const SimulateOptions& o, const std::string& name) {
  return o.config_file.empty() || o.app == nullptr || o.app->get_option(name)->count() > 0;
}

// "default": each container's own default (sim_bag_export.hpp).
std::optional<io::bag::Compression> bag_compression(const std::string& name) {
  if (name == "none") return io::bag::Compression::kNone;
  if (name == "lz4") return io::bag::Compression::kLz4;
  if (name == "zstd") return io::bag::Compression::kZstd;
  if (name == "bz2") return io::bag::Compression::kBz2;
  return std::nullopt;
}

void check_poses_format(const SimulateOptions& o) {
  const PosesFormat f = *parse_poses_format(o.poses_format);
  if (o.format != "opencalib" && f != PosesFormat::kOpenCalib)
    throw UsageError("--poses-format goes with the PCD folder layout, not with --format " + o.format);
  if (is_ins_log_format(f) && !o.config.rig.empty()) throw UsageError("--poses-format " + o.poses_format + " writes one LiDAR (no --rig)");
  if (std::abs(o.ins_clock_offset_s - std::round(o.ins_clock_offset_s)) > 1e-9)
    throw UsageError(fmt::format("--ins-clock-offset-s {} is not a whole number of seconds", o.ins_clock_offset_s));
  if (o.ins_clock_offset_s != 0.0 && (!is_ins_log_format(f) || f == PosesFormat::kKitti))
    throw UsageError("--ins-clock-offset-s needs --poses-format novatel, sbet or csv (a KITTI drive has one clock)");
}

void apply_trajectory(SimulateOptions& o) {
  sim::SimConfig& c = o.config;
  if (const auto kind = enum_from_name<sim::TrajectoryKind>(o.trajectory)) {
    c.trajectory = *kind;
  } else {
    c.trajectory = sim::TrajectoryKind::kRecorded;
    if (!fs::is_regular_file(o.trajectory))
      throw UsageError("--trajectory \"" + o.trajectory +
                       "\" is neither figure8, straight, standstill, city-loop, urban-grid, highway, parking-lot nor an "
                       "existing pose file");
    const io::PoseFile file = io::read_pose_file(o.trajectory);
    bool timed = true;
    for (double t : file.t_s) timed = timed && std::isfinite(t);
    for (std::size_t i = 0; i < file.T_world_ins.size(); ++i) {
      // Frame names that are not times: the OpenCalib sample's 10 Hz.
      const double t = timed ? file.t_s[i] : 0.1 * static_cast<double>(i);
      if (!c.recorded_trajectory.empty() && !(t > c.recorded_trajectory.back().t_s))
        throw InputError(o.trajectory, "line " + std::to_string(file.line[i]), "pose times are not increasing");
      c.recorded_trajectory.push_back({t, file.T_world_ins[i]});
    }
    if (c.recorded_trajectory.size() < 2) throw InputError(o.trajectory, "", "needs at least 2 poses");
  }
}

void apply_options(SimulateOptions& o) {
  if (!o.config_error.empty()) throw UsageError(o.config_error);
  sim::SimConfig& c = o.config;
  if (given(o, "--scene")) c.scene = o.scene == "feature-poor" ? sim::SceneKind::kFeaturePoor : sim::SceneKind::kIntersection;
  if (given(o, "--ins-axes")) c.ins_axes = o.ins_axes == "y-forward" ? sim::InsAxes::kYForward : sim::InsAxes::kXForward;
  if (given(o, "--ins-error") && !sim::parse_ins_error_model(o.ins_error, c.ins_error.model))
    throw UsageError("--ins-error \"" + o.ins_error + "\" is neither rtk-fixed nor drift");
  if (o.ins_drift_m_per_sqrt_s >= 0.0)
    c.ins_error.drift_horizontal_m_per_sqrt_s = c.ins_error.drift_vertical_m_per_sqrt_s = o.ins_drift_m_per_sqrt_s;
  check_poses_format(o);
  if (given(o, "--trajectory")) apply_trajectory(o);
  if (!o.extrinsic.empty()) c.T_ins_lidar = parse_extrinsic(o.extrinsic);
  if (!o.knock.empty()) c.knock = parse_knock(o.knock);
  if (o.frames > 0) c.duration_s = o.frames / c.frame_rate_hz;
}

GroundTruthLabels labels(const SimulateOptions& o) { return {o.trajectory, o.pcd_encoding}; }

void print_plan(const SimulateOptions& o, const sim::World& w) {
  std::size_t frames = 0;
  std::string lidars;
  for (const sim::SimLidar& l : w.lidars) {
    frames += l.frame_times_s.size();
    if (!lidars.empty()) lidars += ", ";
    lidars += is_rig(w) ? l.name + ":" + l.model.name + "@" + l.mount : l.model.name;
  }
  fmt::print(stderr, "simulating {} frames ({}, {}, {}), writing to {}\n", frames, lidars, scene_name(o.config.scene),
             trajectory_name(o.config.trajectory), o.out);
  const std::size_t movers = w.traffic ? w.traffic->movers.size() : 0;
  const int wanted = o.config.traffic + o.config.pedestrians;
  if (wanted > 0) fmt::print(stderr, "traffic: {} of {} movers found room in the lanes and sidewalks\n", movers, wanted);
}

void print_summary(const SimulateOptions& o, const sim::World& w, const fs::path& out, const Rendered& r, double elapsed_s) {
  std::size_t frames = 0, points = 0;
  for (std::size_t i = 0; i < w.lidars.size(); ++i) {
    frames += r.names[i].size();
    points += r.points[i];
  }
  fmt::print("wrote {} frames ({} points, {:.1f} MB) to {} in {:.1f} s\n", frames, points,
             static_cast<double>(directory_bytes(out)) / 1e6, out.string(), elapsed_s);
  for (const sim::SimLidar& l : w.lidars) {
    const Vec3 t = l.T_ins_lidar_true.translation();
    const Vec3 rpy = rpy_from_rotation(l.T_ins_lidar_true.linear()) * kDegPerRad;
    fmt::print("true T_ins_lidar{}: t = [{:.4f} {:.4f} {:.4f}] m, rpy = [{:.3f} {:.3f} {:.3f}] deg, time offset {} s\n",
               is_rig(w) ? " (" + l.name + ")" : std::string(), t.x(), t.y(), t.z(), rpy.x(), rpy.y(), rpy.z(),
               l.time_offset_s);
  }
}

io::NovatelRecord novatel_record(const std::string& name) {
  return name == "inspvaa" ? io::NovatelRecord::kInspvaa : name == "inspvasa" ? io::NovatelRecord::kInspvasa : io::NovatelRecord::kInspvaxa;
}

SimInsOptions ins_log_options(const SimulateOptions& o, const sim::World& w, std::size_t points) {
  SimInsOptions s;
  s.format = *parse_poses_format(o.poses_format);
  s.ins_clock_offset_s = o.ins_clock_offset_s;
  s.log.novatel_record = novatel_record(o.novatel_record);
  s.ground_truth = ground_truth_json(w, points, labels(o));
  s.ground_truth["config"]["poses_format"] = o.poses_format;
  return s;
}

void print_ins_log(const SimInsResult& r) {
  fmt::print("INS: {} records in {}; ins = {}\n", r.records, r.poses.string(), r.ins_frame);
  if (!r.poses_columns.empty()) fmt::print("--poses-columns '{}' (also in poses-columns.txt)\n", r.poses_columns);
  const Vec3 t = r.T_ins_lidar.translation(), rpy = rpy_from_rotation(r.T_ins_lidar.linear()) * kDegPerRad;
  fmt::print("true T_ins_lidar in that frame: t = [{:.4f} {:.4f} {:.4f}] m, rpy = [{:.3f} {:.3f} {:.3f}] deg\n", t.x(), t.y(),
             t.z(), rpy.x(), rpy.y(), rpy.z());
}

// --poses-format kitti: the whole drive in KITTI's layout instead of the PCD folder.
int run_kitti(const SimulateOptions& o, const sim::World& world) {
  ProgressBar bar(o.quiet ? Verbosity::kQuiet : Verbosity::kNormal);
  const auto print = [&bar](std::size_t d, std::size_t n) { bar.update("frames", static_cast<double>(d) / static_cast<double>(n)); };
  const SimInsResult r = write_sim_kitti_raw(world, ins_log_options(o, world, 0), o.out, o.quiet ? SimInsProgress{} : SimInsProgress(print));
  bar.finish();
  fmt::print("wrote a KITTI raw drive of {} frames ({} points) to {} (--kitti-raw {})\n", r.frames, r.points, o.out, r.poses.string());
  print_ins_log(r);
  return kExitOk;
}

int run_simulate(SimulateOptions& o) {
  try {
    apply_options(o);
  } catch (const UsageError& e) {
    fmt::print(stderr, "error: {}\n", e.what());
    return kExitUsage;
  }
  sim::World world;
  try {
    world = sim::build_world(o.config);
  } catch (const std::invalid_argument& e) {
    fmt::print(stderr, "error: {}\n", e.what());
    return kExitUsage;
  }
  const PosesFormat poses_format = *parse_poses_format(o.poses_format);
  if (poses_format == PosesFormat::kKitti) return run_kitti(o, world);
  if (o.format != "opencalib") {  // a recording instead of the PCD folder
    SimBagOptions bag;
    bag.format = *parse_bag_format(o.format);
    bag.lidar_convention = *parse_lidar_convention(o.lidar_convention);
    bag.ins_message = *parse_ins_message(o.ins_message);
    bag.compression = bag_compression(o.bag_compression);
    bag.recorder_chunks = o.bag_chunking == "recorder";
    bag.chunk_bytes = o.bag_chunk_kib * 1024;
    bag.ground_truth = ground_truth_json(world, 0, labels(o));
    ProgressBar bar(o.quiet ? Verbosity::kQuiet : Verbosity::kNormal);
    const auto print = [&bar](std::size_t d, std::size_t n) { bar.update("frames", static_cast<double>(d) / static_cast<double>(n)); };
    const SimBagResult r = write_sim_bag(world, bag, o.out, o.quiet ? SimBagProgress{} : SimBagProgress(print));
    bar.finish();
    fmt::print("wrote {} frames ({} points) and {} INS messages to {}; ins = {}\n", r.frames, r.points, r.ins_messages,
               r.bag.string(), r.ins_frame);
    return kExitOk;
  }
  const fs::path out = o.out;
  const std::vector<fs::path> dirs = lidar_dirs(world, out);
  if (!prepare_dirs(dirs, o.overwrite)) return kExitUsage;
  const io::PcdEncoding encoding = o.pcd_encoding == "ascii"    ? io::PcdEncoding::kAscii
                                   : o.pcd_encoding == "binary" ? io::PcdEncoding::kBinary
                                                                : io::PcdEncoding::kBinaryCompressed;
  if (!o.quiet) print_plan(o, world);
  const auto start = std::chrono::steady_clock::now();
  // A bar on a terminal; in a log one line per step and a progress line at most every 5 s.
  ProgressBar bar(o.quiet ? Verbosity::kQuiet : Verbosity::kNormal);
  const Rendered rendered = render_all(world, dirs, encoding, [&bar](std::size_t d, std::size_t n) {
    bar.update("frames", static_cast<double>(d) / static_cast<double>(n));
  });
  bar.finish();
  if (is_ins_log_format(poses_format)) {  // the INS log and its side files instead of the pose files
    const SimInsResult r = write_sim_ins_log(world, ins_log_options(o, world, rendered.points.front()), out);
    print_summary(o, world, out, rendered, std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
    print_ins_log(r);
    return kExitOk;
  }
  write_metadata(world, out, rendered, labels(o));
  const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  print_summary(o, world, out, rendered, elapsed);
  return kExitOk;
}

// The scene, the drive, the true mount and the wrong guess.
void add_drive_options(CLI::App* sub, SimulateOptions* o) {
  sim::SimConfig& c = o->config;
  sub->add_option("--out", o->out, "output dataset directory (lidar/, poses.txt, ground_truth.json, ...)")->required();
  sub->add_option("--seed", c.seed, "random seed: scene, mount, noise")->capture_default_str();
  sub->add_option("--scene", o->scene, "intersection | feature-poor")
      ->check(CLI::IsMember({"intersection", "feature-poor"}))
      ->capture_default_str();
  sub->add_option("--trajectory", o->trajectory,
                  "figure8 | straight | standstill (calibration drives) | city-loop | urban-grid | highway | parking-lot "
                  "(ordinary drives: stops, turns, 180 s unless --duration-s) | a pose FILE to follow")
      ->capture_default_str();
  sub->add_option("--loops", c.figure8_loops, "figure-8 loops")->check(CLI::Range(1, 100))->capture_default_str();
  auto* frames = sub->add_option("--frames", o->frames, "number of frames (truncates the drive)")
                     ->check(CLI::Range(1, 1000000));
  auto* duration = sub->add_option("--duration-s", c.duration_s, "drive length in seconds (truncates the drive)")
                       ->check(CLI::Range(0.0, 3600.0));
  frames->excludes(duration);
  sub->add_option("--speed-kmh", c.speed_kmh, "cruise speed")->check(CLI::Range(0.1, 120.0))->capture_default_str();
  sub->add_option("--traffic", c.traffic,
                  "moving cars and vans (15-40 km/h in the lanes beside the path, keeping right, both directions)")
      ->check(CLI::Range(0, 500))
      ->capture_default_str();
  sub->add_option("--pedestrians", c.pedestrians,
                  "moving people: 30% cyclists (3-6 m/s, bike lanes), the others walking or jogging (1-3.5 m/s) along "
                  "the sidewalks or crossing")
      ->check(CLI::Range(0, 500))
      ->capture_default_str();
  sub->add_option("--fiducials", c.n_fiducials, "surveyed ground points")->check(CLI::Range(0, 1000))->capture_default_str();
  sub->add_option("--ordinary-speed-kmh", c.ordinary_speed_kmh,
                  "ordinary drives' cruise speed (0: the kind's own: city 30, highway 90, parking 10)")
      ->check(CLI::Range(0.0, 150.0))
      ->capture_default_str();
  sub->add_option("--knock", o->knock,
                  "the mount moved by \"dx dy dz droll dpitch dyaw\" (m, deg, INS frame) since installed-extrinsic.json was "
                  "right (PCD folder layout): the truth is the installed extrinsic knocked");
  sub->add_option("--extrinsic", o->extrinsic, "true T_ins_lidar \"x y z roll pitch yaw\" (m, deg ZYX); default random roof mount");
  sub->add_option("--init-rot-err-deg", c.init_rot_err_deg, "rotation error of init-extrinsic.json")
      ->check(CLI::Range(0.0, 180.0))
      ->capture_default_str();
  sub->add_option("--init-trans-err-m", c.init_trans_err_m, "translation error of init-extrinsic.json")
      ->check(CLI::Range(0.0, 100.0))
      ->capture_default_str();
  sub->add_option("--time-offset-s", c.time_offset_s, "t_ins = t_lidar + offset")->check(CLI::Range(-1.0, 1.0))->capture_default_str();
}

// The LiDAR (or rig) and its noise.
void add_lidar_options(CLI::App* sub, SimulateOptions* o) {
  sim::SimConfig& c = o->config;
  sub->add_option("--rig", c.rig,
                  "several LiDARs: name:model[@mount][/rate_hz],... e.g. top:pandar64,left:vlp16@left,right:vlp16@right,"
                  "front:os1-64@front (mounts: roof, left, right, front, rear, roof-front; each LiDAR its own seeded "
                  "mount, clock offset and spin phase; writes lidar/<name>/, poses-<name>.txt, init-extrinsic-<name>.json)");
  sub->add_option("--rig-clock-spread-s", c.rig_clock_spread_s,
                  "rig: each LiDAR's clock offset is --time-offset-s plus a uniform draw within +-this")
      ->check(CLI::Range(0.0, 0.5))
      ->capture_default_str();
  sub->add_option("--lidar", c.lidar_model, "pandar64 | hdl32 | os1-64 | vlp16 | livox-avia (70.4 deg rosette)")
      ->check(CLI::IsMember(sim::lidar_model_names()))
      ->capture_default_str();
  sub->add_option("--azimuth-step-deg", c.azimuth_step_deg, "horizontal resolution")
      ->check(CLI::Range(0.01, 10.0))
      ->capture_default_str();
  sub->add_option("--range-noise-m", c.range_noise_m, "range noise sigma")->check(CLI::Range(0.0, 1.0))->capture_default_str();
  sub->add_option("--dropout-prob", c.dropout_prob, "probability that a return is lost")
      ->check(CLI::Range(0.0, 0.99))
      ->capture_default_str();
  sub->add_option("--max-range-m", c.max_range_m, "maximum range")->check(CLI::Range(5.0, 1000.0))->capture_default_str();
}

// The INS and its error models.
void add_ins_options(CLI::App* sub, SimulateOptions* o) {
  sim::SimConfig& c = o->config;
  sub->add_option("--ins-axes", o->ins_axes, "INS body axes: x-forward (REP-103) | y-forward (NovAtel)")
      ->check(CLI::IsMember({"x-forward", "y-forward"}))
      ->capture_default_str();
  sub->add_option("--ins-noise-scale", c.ins_noise_scale,
                  "INS white noise (1 cm, 0.01/0.01/0.03 deg) and RTK-fixed bounded error, relative to a NovAtel-class unit "
                  "(0 = perfect)")
      ->check(CLI::Range(0.0, 1000.0))
      ->capture_default_str();
  sub->add_option("--ins-error", o->ins_error,
                  "INS slow error: rtk-fixed (bounded: 1 cm horizontal, 1.5 cm vertical, 30 s Gauss-Markov) | drift (random "
                  "walk from zero at the start: 5 mm/sqrt(s) per axis, heading 0.002 deg/sqrt(s))")
      ->check(CLI::IsMember({"rtk-fixed", "drift"}))
      ->capture_default_str();
  sub->add_option("--ins-drift-m-per-sqrt-s", o->ins_drift_m_per_sqrt_s, "drift model: position random walk per axis (default 0.005)")
      ->check(CLI::Range(0.0, 1.0));
  sub->add_option("--ins-heading-drift-deg-per-sqrt-s", c.ins_error.drift_heading_deg_per_sqrt_s, "drift model: heading random walk")
      ->check(CLI::Range(0.0, 1.0))
      ->capture_default_str();
  sub->add_option("--ins-float-episodes", c.ins_error.float_episodes,
                  "RTK float episodes: position error ramping to 0.3 m and back over 8 s, reported as RTK float with "
                  "stddev 0.1-0.3 m (events keep 15 s from the drive's ends and 5 s apart)")
      ->check(CLI::Range(0, 100))
      ->capture_default_str();
  sub->add_option("--ins-wrong-fixes", c.ins_error.wrong_fixes, "wrong RTK fixes: a 0.5 m jump held 5 s, reported as a normal fix")
      ->check(CLI::Range(0, 100))
      ->capture_default_str();
  sub->add_option("--ins-outages", c.ins_error.outages,
                  "GNSS outages of 10 s: the INS coasts (error growing quadratically to 0.3 m, attitude drifting to "
                  "0.02 deg tilt / 0.05 deg heading), reported as INS-only with a growing stddev")
      ->check(CLI::Range(0, 100))
      ->capture_default_str();
}

// What is written: layout, recording conventions, INS log format.
void add_output_options(CLI::App* sub, SimulateOptions* o) {
  sub->add_option("--format", o->format, "opencalib (PCD folder and pose files) | ros1 | mcap | db3 (a recording)")
      ->check(CLI::IsMember({"opencalib", "ros1", "mcap", "db3"}))
      ->capture_default_str();
  sub->add_option("--bag-compression", o->bag_compression,
                  "recordings: chunk compression default (ros1 lz4, mcap zstd, db3 none) | none | lz4 | zstd (mcap) | bz2 (ros1)")
      ->check(CLI::IsMember({"default", "none", "lz4", "zstd", "bz2"}))
      ->capture_default_str();
  sub->add_option("--bag-chunking", o->bag_chunking,
                  "mcap: insalign (a point cloud gets a chunk of its own) | recorder (clouds and INS messages share "
                  "chunks, as ros2 bag record writes them)")
      ->check(CLI::IsMember({"insalign", "recorder"}))
      ->capture_default_str();
  sub->add_option("--bag-chunk-kib", o->bag_chunk_kib, "recordings: a chunk is closed once it holds this many KiB (ros1, mcap)")
      ->check(CLI::Range(1, 1 << 20))
      ->capture_default_str();
  sub->add_option("--lidar-convention", o->lidar_convention, "recordings: per-point time as hesai | velodyne | ouster | none")
      ->check(CLI::IsMember({"hesai", "velodyne", "ouster", "none"}))
      ->capture_default_str();
  sub->add_option("--ins-message", o->ins_message, "recordings: inspva (INSPVA + INSPVAX) | navsatfix-imu | odometry | tf")
      ->check(CLI::IsMember({"inspva", "navsatfix-imu", "odometry", "tf"}))
      ->capture_default_str();
  sub->add_option("--poses-format", o->poses_format,
                  "opencalib (poses.txt, poses_tum.txt) | tum (the same) | novatel (novatel.log, GPS time, ins = SPAN "
                  "vehicle frame) | sbet (sbet.out, ins = x forward, y right, z down) | csv (ins_export.csv + "
                  "poses-columns.txt) | kitti (a KITTI raw drive: <date>_drive_0001_sync/ + calib_imu_to_velo.txt, ins = "
                  "OXTS frame); INS logs come with geodetic fiducials and ground_truth.json in their ins frame")
      ->check(CLI::IsMember({"opencalib", "tum", "novatel", "sbet", "csv", "kitti"}))
      ->capture_default_str();
  sub->add_option("--novatel-record", o->novatel_record, "novatel: inspvaxa | inspvaa | inspvasa")
      ->check(CLI::IsMember({"inspvaxa", "inspvaa", "inspvasa"}))
      ->capture_default_str();
  sub->add_option("--ins-clock-offset-s", o->ins_clock_offset_s,
                  "novatel, sbet, csv: whole seconds added to every INS stamp (18: an INS on GPS time beside a LiDAR on UTC)")
      ->check(CLI::Range(-86400.0, 86400.0))
      ->capture_default_str();
  sub->add_option("--pcd-encoding", o->pcd_encoding, "binary | binary_compressed | ascii")
      ->check(CLI::IsMember({"binary", "binary_compressed", "ascii"}))
      ->capture_default_str();

}

}  // namespace

Command make_simulate_command() {
  auto o = std::make_shared<SimulateOptions>();
  Command command;
  command.setup = [o](CLI::App& app) {
    CLI::App* sub = app.add_subcommand("simulate", "Simulate a calibration drive with ground truth (OpenCalib layout)");
    o->app = sub;
    // First, so that the file's values are set before the options given beside it (CLI11 assigns
    // in declaration order; this one as soon as it is parsed): the command line wins.
    sub->add_option_function<std::string>(
           "--config",
           [o](const std::string& path) {
             o->config_file = path;
             try {
               o->config = load_tool_config(path).sim;
             } catch (const std::exception& e) {
               o->config_error = e.what();
             }
           },
           "YAML file whose sim: section sets any simulator parameter (see 'insalign config --dump'); options override it")
        ->trigger_on_parse();
    add_drive_options(sub, o.get());
    add_lidar_options(sub, o.get());
    add_ins_options(sub, o.get());
    add_output_options(sub, o.get());
    sub->add_flag("--overwrite", o->overwrite, "replace PCD files already in OUT/lidar");
    sub->add_flag("--quiet", o->quiet, "no progress on stderr");
    return sub;
  };
  command.run = [o] { return run_simulate(*o); };
  return command;
}

}  // namespace insalign::cli
