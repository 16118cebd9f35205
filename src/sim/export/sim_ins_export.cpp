#include "sim/export/sim_ins_export.hpp"

#include <algorithm>
#include <atomic>
#include <stdexcept>

#include "sim/export/sim_bag_export.hpp"
#include "files/atomic_file.hpp"
#include "files/extrinsic_json.hpp"
#include "files/fiducials.hpp"
#include "files/formats.hpp"
#include "inslog/gps_time.hpp"

namespace insalign::cli {
namespace {

namespace fs = std::filesystem;

constexpr PosesFormat kFormats[] = {PosesFormat::kOpenCalib, PosesFormat::kTum, PosesFormat::kNovatel,
                                    PosesFormat::kSbet,      PosesFormat::kCsv, PosesFormat::kKitti};

const char* ins_frame_words(PosesFormat f) {
  switch (f) {
    case PosesFormat::kNovatel: return "NovAtel SPAN vehicle frame (x right, y forward, z up)";
    case PosesFormat::kSbet: return "SBET body frame (x forward, y right, z down)";
    case PosesFormat::kCsv: return "the export's body frame (x forward, y right, z down)";
    case PosesFormat::kKitti: return "OXTS IMU frame (x forward, y left, z up)";
    default: return "the simulator's INS frame";
  }
}

io::InsLogFormat log_format(PosesFormat f) {
  switch (f) {
    case PosesFormat::kNovatel: return io::InsLogFormat::kNovatelAscii;
    case PosesFormat::kSbet: return io::InsLogFormat::kSbet;
    case PosesFormat::kCsv: return io::InsLogFormat::kTextExport;
    case PosesFormat::kKitti: return io::InsLogFormat::kKittiOxts;
    default: break;
  }
  throw std::invalid_argument(std::string("--poses-format ") + poses_format_name(f) + " is a pose file, not an INS log");
}

/// The INS track as the log states it: the reported poses in the format's ins frame, positions
/// relative to the first pose (the ENU origin), stamps on the log's clock.
struct LogTrack {
  std::vector<StampedPose> poses;
  std::vector<InsQuality> quality;
  Vec3 p_first = Vec3::Zero();  ///< the first pose in the simulator's world
};

LogTrack log_track(const sim::World& world, const SimInsOptions& o) {
  const std::vector<StampedPose> reported = sim::dense_reported_poses(world, o.ins_rate_hz);
  if (reported.size() < 2) throw std::invalid_argument("the simulated drive is too short for an INS track");
  const Iso3 T_sim_ins = T_sim_ins_format(world, o.format);
  LogTrack track;
  track.p_first = (reported.front().T_world_ins * T_sim_ins).translation();
  std::vector<double> t_ins;
  for (const StampedPose& p : reported) {
    Iso3 T = p.T_world_ins * T_sim_ins;
    T.translation() -= track.p_first;
    track.poses.push_back({p.t_s + o.ins_clock_offset_s, T});
    t_ins.push_back(p.t_s);
  }
  track.quality = sim::ins_quality_series(world, t_ins);
  for (InsQuality& q : track.quality) q.t_s += o.ins_clock_offset_s;
  return track;
}

void put_extrinsic(nlohmann::json& j, const std::string& prefix, const Iso3& T) {
  const Eigen::Quaterniond q(T.linear());
  const Vec3 rpy = rpy_from_rotation(T.linear()) * kDegPerRad;
  j[prefix] = io::transform_to_json(T);
  if (prefix != "T_ins_lidar") return;
  j["translation_m"] = {T.translation().x(), T.translation().y(), T.translation().z()};
  j["rpy_deg"] = {rpy.x(), rpy.y(), rpy.z()};
  j["quaternion_wxyz"] = {q.w(), q.x(), q.y(), q.z()};
}

// The side files every INS log format shares, in the format's ins frame.
void write_side_files(const sim::World& world, const SimInsOptions& o, const fs::path& out_dir, const LogTrack& track,
                      const SimInsResult& r, const nlohmann::json& ins_log) {
  const Iso3 T_ins_sim = T_sim_ins_format(world, o.format).inverse();
  io::write_opencalib_extrinsic(out_dir / "init-extrinsic.json", T_ins_sim * world.T_ins_lidar_init);
  const insalign::LocalEnu enu(o.log.origin);
  io::write_geodetic_fiducials(out_dir / "fiducials.txt", world.fiducials, enu, -track.p_first);
  nlohmann::json j = o.ground_truth.is_object() ? o.ground_truth : nlohmann::json::object();
  put_extrinsic(j, "T_ins_lidar", r.T_ins_lidar);
  put_extrinsic(j, "T_ins_lidar_init", T_ins_sim * world.T_ins_lidar_init);
  if (!j.contains("time_offset_s")) j["time_offset_s"] = world.config.time_offset_s;
  j["ins_clock_offset_s"] = o.ins_clock_offset_s;
  j["ins_log"] = ins_log;
  if (!r.poses_columns.empty()) j["poses_columns"] = r.poses_columns;
  if (r.frames > 0) j["frames"] = r.frames, j["points"] = r.points;
  io::write_file_atomic(out_dir / "ground_truth.json", j.dump(2) + "\n");
}

nlohmann::json ins_log_json(const SimInsOptions& o, const SimInsResult& r, const fs::path& out_dir) {
  const insalign::GeodeticPoint& g = o.log.origin;
  return {{"format", poses_format_name(o.format)},
          {"path", fs::relative(r.poses, out_dir).string()},
          {"ins_frame", r.ins_frame},
          {"ins_rate_hz", o.ins_rate_hz},
          {"records", r.records},
          {"ins_clock_offset_s", o.ins_clock_offset_s},
          {"enu_origin_deg_deg_m", {g.lat_deg, g.lon_deg, g.height_m}}};
}

void require_single_lidar(const sim::World& world) {
  if (world.lidars.size() != 1) throw std::invalid_argument("--poses-format novatel|sbet|csv|kitti writes one LiDAR (no --rig)");
}

// KITTI's names: the date folder holds <date>_drive_NNNN_sync and calib_imu_to_velo.txt.
std::string kitti_drive_name(double t_unix_s) {
  std::string date = io::format_utc(t_unix_s, 0).substr(0, 10);
  std::replace(date.begin(), date.end(), '-', '_');
  return date + "_drive_0001_sync";
}

}  // namespace

std::optional<PosesFormat> parse_poses_format(std::string_view name) {
  for (PosesFormat f : kFormats) {
    if (name == poses_format_name(f)) return f;
  }
  return std::nullopt;
}

const char* poses_format_name(PosesFormat f) {
  switch (f) {
    case PosesFormat::kOpenCalib: return "opencalib";
    case PosesFormat::kTum: return "tum";
    case PosesFormat::kNovatel: return "novatel";
    case PosesFormat::kSbet: return "sbet";
    case PosesFormat::kCsv: return "csv";
    case PosesFormat::kKitti: return "kitti";
  }
  return "?";
}

bool is_ins_log_format(PosesFormat f) { return f != PosesFormat::kOpenCalib && f != PosesFormat::kTum; }

Iso3 T_sim_ins_format(const sim::World& world, PosesFormat format) {
  if (format == PosesFormat::kNovatel) return T_sim_ins_message(world, InsMessage::kInspva);
  if (!is_ins_log_format(format)) return Iso3::Identity();
  // In the vehicle frame (x forward, y left, z up): SBET and the export x forward, y right, z
  // down; OXTS the vehicle frame itself.
  Iso3 T_vehicle_ins = Iso3::Identity();
  if (format != PosesFormat::kKitti) T_vehicle_ins.linear() = Vec3(1.0, -1.0, -1.0).asDiagonal();
  return world.T_vehicle_ins.inverse() * T_vehicle_ins;
}

SimInsResult write_sim_ins_log(const sim::World& world, const SimInsOptions& o, const fs::path& out_dir) {
  require_single_lidar(world);
  if (o.format == PosesFormat::kKitti) throw std::invalid_argument("KITTI raw drives are written by write_sim_kitti_raw");
  const io::InsLogFormat format = log_format(o.format);
  io::ensure_writable_dir(out_dir);
  const LogTrack track = log_track(world, o);
  SimInsResult r;
  r.poses = out_dir / (o.format == PosesFormat::kNovatel ? "novatel.log" : o.format == PosesFormat::kSbet ? "sbet.out" : "ins_export.csv");
  r.records = track.poses.size();
  r.T_ins_lidar = T_sim_ins_format(world, o.format).inverse() * world.T_ins_lidar_true;
  r.ins_frame = ins_frame_words(o.format);
  io::write_ins_log(r.poses, format, track.poses, track.quality, o.log);
  nlohmann::json ins_log = ins_log_json(o, r, out_dir);
  if (o.format == PosesFormat::kCsv) {
    r.poses_columns = io::kTextExportWriterSpec;
    io::write_file_atomic(out_dir / "poses-columns.txt", r.poses_columns + "\n");
    ins_log["columns_file"] = "poses-columns.txt";
  }
  write_side_files(world, o, out_dir, track, r, ins_log);
  return r;
}

SimInsResult write_sim_kitti_raw(const sim::World& world, const SimInsOptions& options, const fs::path& out_dir,
                                 const SimInsProgress& progress) {
  require_single_lidar(world);
  if (world.lidar.pattern != sim::ScanPattern::kSpinning) throw std::invalid_argument("--poses-format kitti needs a spinning LiDAR (KITTI's HDL-64E)");
  if (options.ins_clock_offset_s != 0.0) {
    throw std::invalid_argument("--ins-clock-offset-s: a KITTI raw drive stamps every stream with one clock");
  }
  SimInsOptions o = options;
  o.format = PosesFormat::kKitti;
  io::ensure_writable_dir(out_dir);
  const LogTrack track = log_track(world, o);
  SimInsResult r;
  r.poses = out_dir / kitti_drive_name(world.frame_times_s.front());
  r.records = track.poses.size();
  r.frames = world.frame_count();
  const Iso3 T_ins_sim = T_sim_ins_format(world, o.format).inverse();
  r.T_ins_lidar = T_ins_sim * world.T_ins_lidar_true;
  r.ins_frame = ins_frame_words(o.format);
  std::atomic<std::size_t> points{0};
  const auto sweep_at = [&](std::size_t k) {
    Sweep s = sim::render_sweep(world, k);
    points += s.size();
    return s;
  };
  const auto done = [&](std::size_t n) {
    if (progress) progress(n, r.frames);
  };
  io::write_kitti_drive(r.poses, r.frames, sweep_at, track.poses, track.quality, T_ins_sim * world.T_ins_lidar_init, o.log,
                        done);
  r.points = points;
  nlohmann::json ins_log = ins_log_json(o, r, out_dir);
  ins_log["calib_file"] = io::kKittiFile;
  write_side_files(world, o, out_dir, track, r, ins_log);
  return r;
}

}  // namespace insalign::cli
