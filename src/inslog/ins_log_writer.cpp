#include "inslog/ins_log_writer.hpp"

#include <fmt/format.h>
#include <tbb/parallel_for.h>

#include <atomic>
#include <cmath>
#include <fstream>
#include <limits>
#include <mutex>
#include <stdexcept>

#include "core/errors.hpp"
#include "files/atomic_file.hpp"
#include "files/formats.hpp"
#include "inslog/attitude.hpp"
#include "inslog/gps_time.hpp"
#include "inslog/kitti.hpp"
#include "inslog/novatel_ascii.hpp"
#include "inslog/sbet.hpp"

namespace insalign::io {
namespace {

constexpr double kDefaultStddevM = 0.02;  // written where the quality states none

// A pose as the geodetic formats write it.
struct Sample {
  double t_s = 0.0;
  GeodeticPoint p;
  Mat3 R_enu_ins = Mat3::Identity();  ///< in the local ENU frame at p
  Vec3 v_enu_mps = Vec3::Zero();      ///< local ENU at p
  GnssSolution solution = GnssSolution::kUnknown;
  Vec3 sd_enu_m = Vec3::Constant(kDefaultStddevM);
};

std::vector<Sample> samples_of(const std::vector<StampedPose>& poses, const std::vector<InsQuality>& quality,
                               const GeodeticPoint& origin) {
  if (!quality.empty() && quality.size() != poses.size()) {
    throw std::invalid_argument("INS log writer: quality must be empty or one per pose");
  }
  const LocalEnu enu(origin);
  std::vector<Sample> out(poses.size());
  for (std::size_t i = 0; i < poses.size(); ++i) {
    if (i > 0 && !(poses[i].t_s > poses[i - 1].t_s)) throw std::invalid_argument("INS log writer: times must increase");
    Sample& s = out[i];
    s.t_s = poses[i].t_s;
    s.p = enu.geodetic(poses[i].T_world_ins.translation());
    const Mat3 R_world_enuP = enu.rotation_at(s.p);
    s.R_enu_ins = R_world_enuP.transpose() * poses[i].T_world_ins.linear();
    const std::size_t a = i == 0 ? 0 : i - 1, b = i + 1 < poses.size() ? i + 1 : i;
    if (b > a) {
      const Vec3 v_world = (poses[b].T_world_ins.translation() - poses[a].T_world_ins.translation()) /
                           (poses[b].t_s - poses[a].t_s);
      s.v_enu_mps = R_world_enuP.transpose() * v_world;
    }
    if (!quality.empty()) {
      s.solution = quality[i].solution;
      if (std::isfinite(quality[i].horizontal_stddev_m)) s.sd_enu_m.head<2>().setConstant(quality[i].horizontal_stddev_m / std::sqrt(2.0));
      if (std::isfinite(quality[i].vertical_stddev_m)) s.sd_enu_m.z() = quality[i].vertical_stddev_m;
    }
  }
  return out;
}

// Header seconds as NovAtel prints them (ms) when exact, with microseconds otherwise.
std::string sow_text(double sow) {
  const double ms = sow * 1000.0;
  return std::abs(ms - std::round(ms)) < 1e-3 ? fmt::format("{:.3f}", sow) : fmt::format("{:.6f}", sow);
}

const char* ins_status_of(GnssSolution s) {
  switch (s) {
    case GnssSolution::kInsOnly: return "INS_SOLUTION_FREE";
    case GnssSolution::kInvalid: return "INS_HIGH_VARIANCE";
    default: return "INS_SOLUTION_GOOD";
  }
}

const char* pos_type_of(GnssSolution s) {
  switch (s) {
    case GnssSolution::kRtkFloat: return "INS_RTKFLOAT";
    case GnssSolution::kDifferential: return "INS_PSRDIFF";
    case GnssSolution::kSingle: return "INS_PSRSP";
    case GnssSolution::kInsOnly: return "NONE";
    default: return "INS_RTKFIXED";
  }
}

std::string novatel_line(char lead, const std::string& content) {
  return fmt::format("{}{}*{:08x}\r\n", lead, content, novatel_crc32(content));
}

std::string novatel_record(const Sample& s, NovatelRecord kind, double undulation_m) {
  const GpsWeekSeconds g = unix_to_gps(s.t_s);
  const AttitudeDeg a = novatel_angles(s.R_enu_ins);
  const Vec3& v = s.v_enu_mps;
  if (kind == NovatelRecord::kInspvaxa) {
    return novatel_line('#', fmt::format(
        "INSPVAXA,COM1,0,50.0,FINESTEERING,{},{},02000020,46eb,16809;{},{},{:.11f},{:.11f},{:.4f},{:.4f},{:.4f},{:.4f},"
        "{:.4f},{:.9f},{:.9f},{:.9f},{:.4f},{:.4f},{:.4f},0.0100,0.0100,0.0100,0.0100,0.0100,0.0200,00000000,0",
        g.week, sow_text(g.seconds_of_week), ins_status_of(s.solution), pos_type_of(s.solution), s.p.lat_deg,
        s.p.lon_deg, s.p.height_m - undulation_m, undulation_m, v.y(), v.x(), v.z(), a.roll_deg, a.pitch_deg,
        a.heading_deg, s.sd_enu_m.y(), s.sd_enu_m.x(), s.sd_enu_m.z()));
  }
  const std::string body = fmt::format("{},{:.9f},{:.11f},{:.11f},{:.4f},{:.4f},{:.4f},{:.4f},{:.9f},{:.9f},{:.9f},{}",
                                       g.week, g.seconds_of_week, s.p.lat_deg, s.p.lon_deg, s.p.height_m, v.y(), v.x(),
                                       v.z(), a.roll_deg, a.pitch_deg, a.heading_deg, ins_status_of(s.solution));
  const std::string header_sow = fmt::format("{:.3f}", g.seconds_of_week);
  if (kind == NovatelRecord::kInspvaa) {
    return novatel_line('#', fmt::format("INSPVAA,COM1,0,50.0,FINESTEERING,{},{},02000020,18bc,16809;{}", g.week,
                                         header_sow, body));
  }
  return novatel_line('%', fmt::format("INSPVASA,{},{};{}", g.week, header_sow, body));
}

int gga_of(GnssSolution s) {
  switch (s) {
    case GnssSolution::kRtkFixed: return 4;
    case GnssSolution::kRtkFloat: return 5;
    case GnssSolution::kDifferential: return 2;
    case GnssSolution::kSingle: return 1;
    case GnssSolution::kInsOnly: return 6;
    case GnssSolution::kInvalid: return 0;
    default: return 7;  // "manual input": read back as unknown
  }
}

int oxts_posmode_of(GnssSolution s) {
  switch (s) {
    case GnssSolution::kRtkFixed: case GnssSolution::kInvalid: return 6;
    case GnssSolution::kRtkFloat: return 5;
    case GnssSolution::kDifferential: return 4;
    case GnssSolution::kSingle: return 3;
    case GnssSolution::kInsOnly: return 0;
    default: return 19;  // "not recognised": read back as unknown
  }
}

std::string oxts_line(const Sample& s) {
  const AttitudeDeg a = enu_angles(s.R_enu_ins);
  const Vec3 v_body = s.R_enu_ins.transpose() * s.v_enu_mps;  // forward, left, up
  const int navstat = s.solution == GnssSolution::kInvalid ? 0 : 4;
  const int mode = oxts_posmode_of(s.solution);
  return fmt::format("{:.14g} {:.14g} {:.6f} {:.12g} {:.12g} {:.12g} {:.6f} {:.6f} {:.6f} {:.6f} {:.6f} 0 0 0 0 0 0 0 0 0 0 "
                     "0 0 {:.6f} 0.01 {} 10 {} {} 0\n",
                     s.p.lat_deg, s.p.lon_deg, s.p.height_m, a.roll_deg * kRadPerDeg, a.pitch_deg * kRadPerDeg,
                     a.heading_deg * kRadPerDeg, s.v_enu_mps.y(), s.v_enu_mps.x(), v_body.x(), v_body.y(), v_body.z(),
                     s.sd_enu_m.x(), navstat, mode, mode);
}

// Least-squares t = t_start + fraction * (t_end - t_start) over the sweep's points.
std::pair<double, double> fitted_sweep_span(const Sweep& sweep) {
  if (!sweep.has_time() || sweep.size() < 2) throw std::invalid_argument("KITTI writer: sweeps need per-point times");
  double sf = 0, st = 0, sff = 0, sft = 0;
  const double n = static_cast<double>(sweep.size());
  for (std::size_t i = 0; i < sweep.size(); ++i) {
    const double f = kitti_sweep_fraction(sweep.p_lidar[i].x(), sweep.p_lidar[i].y());
    const double t = sweep.dt_s[i];
    sf += f, st += t, sff += f * f, sft += f * t;
  }
  const double det = n * sff - sf * sf;
  if (!(det > 0.0)) throw std::invalid_argument("KITTI writer: sweep points span no azimuth");
  const double span = (n * sft - sf * st) / det, start = (st - span * sf) / n;
  double worst = 0.0;
  for (std::size_t i = 0; i < sweep.size(); ++i) {
    const double f = kitti_sweep_fraction(sweep.p_lidar[i].x(), sweep.p_lidar[i].y());
    worst = std::max(worst, std::abs(start + span * f - sweep.dt_s[i]));
  }
  if (!(span > 0.0) || worst > 1e-3) {
    throw std::invalid_argument(fmt::format("KITTI writer: sweep '{}' is not a clockwise spin starting behind the sensor "
                                            "(point times off the azimuth fit by {:.3g} s)", sweep.name, worst));
  }
  return {sweep.t_end_s + start, sweep.t_end_s + start + span};
}

// Folders of many small files (oxts/data, velodyne_points/data) are written in full under a
// temporary name and renamed into place: atomic as a whole without an fsync per file.
void write_plain(const std::filesystem::path& path, std::string_view content) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(content.data(), static_cast<std::streamsize>(content.size()));
  if (!out.flush()) throw InputError(path.string(), "", "cannot write");
}

std::filesystem::path partial_dir(const std::filesystem::path& dir) {
  std::filesystem::path p = std::filesystem::absolute(dir).lexically_normal();
  if (p.filename().empty()) p = p.parent_path();
  const std::filesystem::path partial = p.parent_path() / (p.filename().string() + ".partial");
  std::filesystem::remove_all(partial);
  ensure_writable_dir(partial / "data");
  return partial;
}

void move_into_place(const std::filesystem::path& partial, const std::filesystem::path& dir) {
  std::error_code ec;
  std::filesystem::remove_all(dir, ec);
  std::filesystem::rename(partial, dir, ec);
  if (ec) throw InputError(dir.string(), "", "cannot move the written folder into place: " + ec.message());
}

}  // namespace

TextExportColumns text_export_writer_columns() { return parse_text_export_columns(kTextExportWriterSpec, "writer"); }

void write_novatel_ascii(const std::filesystem::path& path, const std::vector<StampedPose>& poses,
                         const std::vector<InsQuality>& quality, const InsLogWriteOptions& options) {
  std::string out;
  for (const Sample& s : samples_of(poses, quality, options.origin)) {
    out += novatel_record(s, options.novatel_record, options.undulation_m);
  }
  write_file_atomic(path, out);
}

void write_sbet(const std::filesystem::path& path, const std::vector<StampedPose>& poses, const InsLogWriteOptions& options) {
  const auto samples = samples_of(poses, {}, options.origin);
  std::string out;
  if (samples.empty()) return write_file_atomic(path, out);
  const int week = unix_to_gps(samples.front().t_s).week;
  const double w = options.sbet_wander_deg * kRadPerDeg, cw = std::cos(w), sw = std::sin(w);
  for (const Sample& s : samples) {
    const AttitudeDeg a = ned_angles(s.R_enu_ins);
    const double vn = s.v_enu_mps.y(), ve = s.v_enu_mps.x();
    SbetRecord r{};
    r.time_sow_s = unix_to_gps_seconds(s.t_s) - week * kSecondsPerGpsWeek;
    r.lat_rad = s.p.lat_deg * kRadPerDeg, r.lon_rad = s.p.lon_deg * kRadPerDeg, r.height_m = s.p.height_m;
    r.vx_mps = cw * vn - sw * ve, r.vy_mps = -sw * vn - cw * ve, r.vz_mps = s.v_enu_mps.z();  // wander frame: x north, y west at w = 0
    r.roll_rad = a.roll_deg * kRadPerDeg, r.pitch_rad = a.pitch_deg * kRadPerDeg;
    r.platform_heading_rad = (a.heading_deg + options.sbet_wander_deg) * kRadPerDeg;
    r.wander_rad = w;
    const auto bytes = sbet_record_bytes(r);
    out.append(bytes.data(), bytes.size());
  }
  write_file_atomic(path, out);
}

void write_text_export(const std::filesystem::path& path, const std::vector<StampedPose>& poses,
                       const std::vector<InsQuality>& quality, const InsLogWriteOptions& options) {
  std::string out = "GPSWeek,GPSSeconds,Latitude,Longitude,HeightMSL,Undulation,Roll,Pitch,Heading,SDEast,SDNorth,SDUp,Fix\n";
  for (const Sample& s : samples_of(poses, quality, options.origin)) {
    const GpsWeekSeconds g = unix_to_gps(s.t_s);
    const AttitudeDeg a = ned_angles(s.R_enu_ins);
    out += fmt::format("{},{:.6f},{:.11f},{:.11f},{:.4f},{:.4f},{:.9f},{:.9f},{:.9f},{:.4f},{:.4f},{:.4f},{}\n", g.week,
                       g.seconds_of_week, s.p.lat_deg, s.p.lon_deg, s.p.height_m - options.undulation_m,
                       options.undulation_m, a.roll_deg, a.pitch_deg, a.heading_deg, s.sd_enu_m.x(), s.sd_enu_m.y(),
                       s.sd_enu_m.z(), gga_of(s.solution));
  }
  write_file_atomic(path, out);
}

void write_kitti_oxts(const std::filesystem::path& oxts_dir, const std::vector<StampedPose>& poses,
                      const std::vector<InsQuality>& quality, const InsLogWriteOptions& options) {
  const auto samples = samples_of(poses, quality, options.origin);
  const std::filesystem::path partial = partial_dir(oxts_dir);
  std::vector<double> t;
  for (std::size_t i = 0; i < samples.size(); ++i) {
    write_plain(partial / "data" / fmt::format("{:010}.txt", i), oxts_line(samples[i]));
    t.push_back(samples[i].t_s);
  }
  write_kitti_timestamps(partial / "timestamps.txt", t);
  move_into_place(partial, oxts_dir);
}

void write_ins_log(const std::filesystem::path& path, InsLogFormat format, const std::vector<StampedPose>& poses,
                   const std::vector<InsQuality>& quality, const InsLogWriteOptions& options) {
  switch (format) {
    case InsLogFormat::kNovatelAscii: return write_novatel_ascii(path, poses, quality, options);
    case InsLogFormat::kSbet: return write_sbet(path, poses, options);
    case InsLogFormat::kTextExport: return write_text_export(path, poses, quality, options);
    case InsLogFormat::kKittiOxts: return write_kitti_oxts(path, poses, quality, options);
  }
}

void write_kitti_drive(const std::filesystem::path& drive_dir, const std::vector<Sweep>& sweeps,
                       const std::vector<StampedPose>& poses, const std::vector<InsQuality>& quality,
                       const Iso3& T_ins_lidar_calib, const InsLogWriteOptions& options) {
  write_kitti_drive(drive_dir, sweeps.size(), [&sweeps](std::size_t i) { return sweeps[i]; }, poses, quality,
                    T_ins_lidar_calib, options);
}

void write_kitti_drive(const std::filesystem::path& drive_dir, std::size_t sweep_count,
                       const std::function<Sweep(std::size_t)>& sweep_at, const std::vector<StampedPose>& poses,
                       const std::vector<InsQuality>& quality, const Iso3& T_ins_lidar_calib,
                       const InsLogWriteOptions& options, const std::function<void(std::size_t)>& done) {
  write_kitti_oxts(drive_dir / "oxts", poses, quality, options);
  const std::filesystem::path velo = partial_dir(drive_dir / "velodyne_points");
  std::vector<double> t_start(sweep_count), t_end(sweep_count), t_forward(sweep_count);
  std::atomic<std::size_t> written{0};
  std::mutex report;
  tbb::parallel_for(std::size_t{0}, sweep_count, [&](std::size_t i) {
    const Sweep sweep = sweep_at(i);
    const auto [start, end] = fitted_sweep_span(sweep);
    t_start[i] = start, t_end[i] = end, t_forward[i] = 0.5 * (start + end);
    write_kitti_velodyne(velo / "data" / fmt::format("{:010}.bin", i), sweep);
    const std::size_t n = ++written;
    if (done) {
      const std::lock_guard<std::mutex> lock(report);
      done(n);
    }
  });
  write_kitti_timestamps(velo / "timestamps_start.txt", t_start);
  write_kitti_timestamps(velo / "timestamps_end.txt", t_end);
  write_kitti_timestamps(velo / "timestamps.txt", t_forward);
  move_into_place(velo, drive_dir / "velodyne_points");
  std::filesystem::path drive = std::filesystem::absolute(drive_dir).lexically_normal();
  if (drive.filename().empty()) drive = drive.parent_path();
  const std::filesystem::path date_dir = drive.parent_path();
  write_file_atomic(date_dir / kKittiFile, format_kitti_imu_to_velo(T_ins_lidar_calib));
}

}  // namespace insalign::io
