#include "inslog/kitti.hpp"

#include <fmt/format.h>

#include <bit>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <memory>
#include <stdexcept>

#include "core/errors.hpp"
#include "files/atomic_file.hpp"
#include "files/formats.hpp"
#include "inslog/attitude.hpp"
#include "inslog/gps_time.hpp"
#include "files/read_file.hpp"

namespace insalign::io {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr std::size_t kOxtsFields = 30;
constexpr std::size_t kVelodynePointBytes = 16;

std::string line_at(std::size_t index0) { return "line " + std::to_string(index0 + 1); }

std::string indexed_name(std::size_t i) { return fmt::format("{:010}", i); }

bool all_digits(std::string_view s) {
  if (s.empty()) return false;
  for (const char c : s) {
    if (c < '0' || c > '9') return false;
  }
  return true;
}

int to_int(std::string_view s) {
  int v = 0;
  std::from_chars(s.data(), s.data() + s.size(), v);
  return v;
}

std::vector<std::string_view> split_ws(std::string_view s) {
  std::vector<std::string_view> out;
  std::size_t i = 0;
  while (i < s.size()) {
    while (i < s.size() && (s[i] == ' ' || s[i] == '\t' || s[i] == '\r' || s[i] == '\n')) ++i;
    std::size_t j = i;
    while (j < s.size() && !(s[j] == ' ' || s[j] == '\t' || s[j] == '\r' || s[j] == '\n')) ++j;
    if (j > i) out.push_back(s.substr(i, j - i));
    i = j;
  }
  return out;
}

float le_float(const char* p) {
  std::uint32_t bits = 0;
  std::memcpy(&bits, p, 4);
  if constexpr (std::endian::native == std::endian::big) bits = __builtin_bswap32(bits);
  return std::bit_cast<float>(bits);
}

void put_le_float(float v, std::string& out) {
  std::uint32_t bits = std::bit_cast<std::uint32_t>(v);
  if constexpr (std::endian::native == std::endian::big) bits = __builtin_bswap32(bits);
  char b[4];
  std::memcpy(b, &bits, 4);
  out.append(b, 4);
}

// Integer codes written as numbers; anything beyond int range is no valid code.
int as_code(double v) { return v >= -1e6 && v <= 1e6 ? static_cast<int>(v) : -1; }

GnssSolution oxts_solution(int navstat, int posmode) {
  if (navstat != 4 && navstat != 22) return GnssSolution::kInvalid;
  return oxts_gps_mode_solution(posmode);
}

// Timestamps of a velodyne_points/ file that may be missing (start/end of older extracts).
std::optional<std::vector<double>> optional_timestamps(const std::filesystem::path& file) {
  if (!std::filesystem::exists(file)) return std::nullopt;
  return read_kitti_timestamps(file);
}

void check_count(const std::vector<double>& t, std::size_t n, const std::filesystem::path& file) {
  if (t.size() != n) {
    throw InputError(file.string(), "", fmt::format("{} times, but timestamps.txt has {}", t.size(), n));
  }
}

std::vector<KittiFrame> kitti_frames(const std::filesystem::path& velo_dir, std::vector<std::string>& warnings) {
  const std::vector<double> t_forward = read_kitti_timestamps(velo_dir / "timestamps.txt");
  auto t_start = optional_timestamps(velo_dir / "timestamps_start.txt");
  auto t_end = optional_timestamps(velo_dir / "timestamps_end.txt");
  if (!t_start || !t_end) {
    warnings.push_back("velodyne_points has no timestamps_start.txt / timestamps_end.txt: sweeps taken as 0.1 s "
                       "centred on timestamps.txt");
  }
  if (t_start) check_count(*t_start, t_forward.size(), velo_dir / "timestamps_start.txt");
  if (t_end) check_count(*t_end, t_forward.size(), velo_dir / "timestamps_end.txt");
  std::vector<KittiFrame> frames;
  std::size_t missing = 0;
  for (std::size_t i = 0; i < t_forward.size(); ++i) {
    KittiFrame f;
    f.name = indexed_name(i);
    f.bin = velo_dir / "data" / (f.name + ".bin");
    f.t_forward_s = t_forward[i];
    f.t_start_s = t_start ? (*t_start)[i] : t_forward[i] - 0.05;
    f.t_end_s = t_end ? (*t_end)[i] : t_forward[i] + 0.05;
    if (!(f.t_end_s > f.t_start_s && f.t_end_s - f.t_start_s < 1.0)) {
      throw InputError((velo_dir / "timestamps_end.txt").string(), line_at(i),
                       fmt::format("sweep end {:.6f} is not within 1 s after its start {:.6f}", f.t_end_s, f.t_start_s));
    }
    if (!frames.empty() && !(f.t_end_s > frames.back().t_end_s)) {
      throw InputError((velo_dir / "timestamps_end.txt").string(), line_at(i), "sweep end times do not increase");
    }
    if (!std::filesystem::exists(f.bin)) {
      ++missing;
      continue;
    }
    frames.push_back(f);
  }
  if (missing > 0) warnings.push_back(fmt::format("{} sweeps listed in timestamps.txt have no .bin: skipped", missing));
  return frames;
}

}  // namespace

GnssSolution oxts_gps_mode_solution(int m) {
  switch (m) {
    case 6: case 16: case 24: case 29: return GnssSolution::kRtkFixed;
    case 5: case 15: case 23: case 28: return GnssSolution::kRtkFloat;
    case 4: case 7: case 8: case 9: case 14: case 17: case 18: case 22: case 27: case 30: case 31:
      return GnssSolution::kDifferential;
    case 3: case 13: case 21: case 26: return GnssSolution::kSingle;
    case 0: case 1: case 2: case 10: case 11: case 12: case 20: case 25: return GnssSolution::kInsOnly;
    default: return GnssSolution::kUnknown;
  }
}

std::optional<double> parse_kitti_time(std::string_view s) {
  while (!s.empty() && (s.back() == '\r' || s.back() == ' ')) s.remove_suffix(1);
  // YYYY-MM-DD HH:MM:SS[.fraction]
  if (s.size() < 19 || s[4] != '-' || s[7] != '-' || s[10] != ' ' || s[13] != ':' || s[16] != ':') return std::nullopt;
  const std::string_view parts[] = {s.substr(0, 4), s.substr(5, 2), s.substr(8, 2), s.substr(11, 2), s.substr(14, 2), s.substr(17, 2)};
  for (const auto p : parts) {
    if (!all_digits(p)) return std::nullopt;
  }
  const int mo = to_int(parts[1]), d = to_int(parts[2]), h = to_int(parts[3]), mi = to_int(parts[4]), sec = to_int(parts[5]);
  if (mo < 1 || mo > 12 || d < 1 || d > 31 || h > 23 || mi > 59 || sec > 60) return std::nullopt;
  double frac = 0.0;
  if (s.size() > 19) {
    const std::string_view f = s.substr(20);
    if (s[19] != '.' || !all_digits(f) || f.size() > 12) return std::nullopt;
    frac = static_cast<double>(std::stoll(std::string(f))) * std::pow(10.0, -static_cast<double>(f.size()));
  }
  return utc_to_unix(to_int(parts[0]), mo, d, h, mi, sec) + frac;
}

std::vector<double> read_kitti_timestamps(const std::filesystem::path& file) {
  const std::string text = read_file(file);
  std::vector<double> out;
  std::size_t pos = 0, index = 0;
  while (pos < text.size()) {
    std::size_t nl = text.find('\n', pos);
    if (nl == std::string::npos) nl = text.size();
    const std::string_view line(text.data() + pos, nl - pos);
    pos = nl + 1;
    const std::size_t i = index++;
    if (split_ws(line).empty()) continue;
    const auto t = parse_kitti_time(line);
    if (!t) throw InputError(file.string(), line_at(i), fmt::format("'{}' is not a time like 2011-09-26 13:02:25.964389445", line));
    out.push_back(*t);
  }
  return out;
}

InsRecord parse_kitti_oxts_record(std::string_view text, double t_s, const std::string& file, const std::string& where) {
  const auto tok = split_ws(text);
  if (tok.size() != kOxtsFields) {
    throw InputError(file, where, fmt::format("{} values, an oxts record has {}", tok.size(), kOxtsFields));
  }
  double v[kOxtsFields];
  for (std::size_t i = 0; i < kOxtsFields; ++i) {
    const auto [ptr, ec] = std::from_chars(tok[i].data(), tok[i].data() + tok[i].size(), v[i]);
    if (ec != std::errc() || ptr != tok[i].data() + tok[i].size() || !std::isfinite(v[i])) {
      throw InputError(file, where, fmt::format("value {} is not a finite number: '{}'", i + 1, tok[i]));
    }
  }
  InsRecord r;
  r.t_s = t_s;
  r.lat_deg = v[0], r.lon_deg = v[1], r.height_m = v[2];
  try {
    check_geodetic({r.lat_deg, r.lon_deg, r.height_m});
  } catch (const std::invalid_argument& e) {
    throw InputError(file, where, e.what());
  }
  r.R_world_ins = R_enu_ins_enu(v[3] * kDegPerRad, v[4] * kDegPerRad, v[5] * kDegPerRad);
  r.position_stddev_m = Vec3(v[23], v[23], std::numeric_limits<double>::quiet_NaN());
  r.solution = oxts_solution(as_code(v[25]), as_code(v[27]));
  r.location = file + ":" + where;
  return r;
}

bool is_kitti_oxts_dir(const std::filesystem::path& dir) {
  std::error_code ec;
  if (!std::filesystem::is_directory(dir / "data", ec) || !std::filesystem::is_regular_file(dir / "timestamps.txt", ec)) {
    return false;
  }
  for (const auto& e : std::filesystem::directory_iterator(dir / "data", ec)) {
    if (e.path().extension() == ".txt") return true;
  }
  return false;
}

InsTrack read_kitti_oxts(const std::filesystem::path& oxts_dir) {
  const std::filesystem::path stamps = oxts_dir / "timestamps.txt";
  const std::vector<double> t = read_kitti_timestamps(stamps);
  if (t.empty()) throw InputError(stamps.string(), "", "no timestamps");
  InsTrack track;
  track.source = oxts_dir.string();
  for (std::size_t i = 0; i < t.size(); ++i) {
    const std::filesystem::path file = oxts_dir / "data" / (indexed_name(i) + ".txt");
    if (i > 0 && !(t[i] > t[i - 1])) {
      throw InputError(stamps.string(), line_at(i),
                       t[i] == t[i - 1] ? "a repeated time" : "time goes backwards (the line before is later)");
    }
    track.records.push_back(parse_kitti_oxts_record(read_file(file), t[i], file.string(), "line 1"));
  }
  track.format = "KITTI raw oxts (OXTS RT3003, 30 values per record)";
  track.time_base = "KITTI timestamps.txt (the recording computer's clock, no time zone given; read as UTC)";
  track.body_frame = "OXTS IMU frame (x forward, y left, z up; yaw 0 = east, counter-clockwise)";
  track.height_datum = "alt as the OXTS wrote it (about mean sea level, no undulation given; used as is)";
  track.world_frame = "local ENU at the first fix";
  track.geodetic = true;
  return track;
}

double kitti_sweep_fraction(double x_m, double y_m, VelodyneSpin spin) {
  const double a = std::atan2(y_m, x_m);  // (-pi, pi]
  const double f = spin == VelodyneSpin::kClockwise ? (kPi - a) / (2 * kPi) : (a + kPi) / (2 * kPi);
  return f >= 1.0 ? 0.0 : f;
}

Sweep parse_kitti_velodyne(std::string_view bytes, const std::string& name, const std::string& file, double t_start_s,
                           double t_end_s, VelodyneSpin spin) {
  if (bytes.size() % kVelodynePointBytes != 0) {
    throw InputError(file, "byte " + std::to_string(bytes.size() / kVelodynePointBytes * kVelodynePointBytes),
                     fmt::format("size {} bytes is not a multiple of 16 (float32 x y z reflectance per point)", bytes.size()));
  }
  Sweep s;
  s.name = name;
  s.t_end_s = t_end_s;
  const std::size_t n = bytes.size() / kVelodynePointBytes;
  s.p_lidar.reserve(n), s.dt_s.reserve(n), s.intensity.reserve(n);
  const double span_s = t_end_s - t_start_s;
  for (std::size_t i = 0; i < n; ++i) {
    const char* p = bytes.data() + i * kVelodynePointBytes;
    const Vec3f xyz(le_float(p), le_float(p + 4), le_float(p + 8));
    const float reflectance = le_float(p + 12);
    if (!xyz.allFinite() || !std::isfinite(reflectance)) continue;
    const double t = t_start_s + kitti_sweep_fraction(xyz.x(), xyz.y(), spin) * span_s;
    s.p_lidar.push_back(xyz);
    s.dt_s.push_back(static_cast<float>(t - t_end_s));
    s.intensity.push_back(reflectance);
  }
  return s;
}

Sweep read_kitti_velodyne(const std::filesystem::path& bin, double t_start_s, double t_end_s, VelodyneSpin spin) {
  return parse_kitti_velodyne(read_file(bin), bin.stem().string(), bin.string(), t_start_s, t_end_s, spin);
}

KittiDrive read_kitti_drive(const std::filesystem::path& drive_dir_in, VelodyneSpin spin) {
  std::filesystem::path drive_dir = std::filesystem::absolute(drive_dir_in).lexically_normal();
  if (drive_dir.filename().empty()) drive_dir = drive_dir.parent_path();  // "drive/" names the folder too
  if (!std::filesystem::is_directory(drive_dir / "velodyne_points") || !std::filesystem::is_directory(drive_dir / "oxts")) {
    throw InputError(drive_dir.string(), "", "not a KITTI raw drive folder: it needs velodyne_points/ and oxts/");
  }
  KittiDrive d;
  d.drive_dir = drive_dir;
  d.spin = spin;
  d.frames = kitti_frames(drive_dir / "velodyne_points", d.warnings);
  if (d.frames.empty()) throw InputError((drive_dir / "velodyne_points").string(), "", "no sweeps (.bin files)");
  d.ins = read_kitti_oxts(drive_dir / "oxts");
  d.calib_file = drive_dir.parent_path() / kKittiFile;
  if (std::filesystem::exists(d.calib_file)) {
    d.T_ins_lidar_init = parse_kitti_imu_to_velo(read_file(d.calib_file), d.calib_file.string()).T_parent_child;
  } else {
    d.warnings.push_back(fmt::format("no {}: no initial extrinsic from the drive", d.calib_file.string()));
  }
  return d;
}

FrameSource kitti_frame_source(const KittiDrive& drive) {
  FrameSource source;
  auto frames = std::make_shared<const std::vector<KittiFrame>>(drive.frames);
  for (const KittiFrame& f : drive.frames) source.frames.push_back({f.name, f.t_end_s});
  const VelodyneSpin spin = drive.spin;
  source.load = [frames, spin](std::size_t i) {
    const KittiFrame& f = frames->at(i);
    return read_kitti_velodyne(f.bin, f.t_start_s, f.t_end_s, spin);
  };
  return source;
}

void write_kitti_timestamps(const std::filesystem::path& file, const std::vector<double>& t_unix_s) {
  std::string out;
  for (const double t : t_unix_s) out += format_utc(t, 9) + "\n";
  write_file_atomic(file, out);
}

void write_kitti_velodyne(const std::filesystem::path& bin, const Sweep& sweep) {
  std::string out;
  out.reserve(sweep.size() * kVelodynePointBytes);
  for (std::size_t i = 0; i < sweep.size(); ++i) {
    const Vec3f& p = sweep.p_lidar[i];
    put_le_float(p.x(), out), put_le_float(p.y(), out), put_le_float(p.z(), out);
    put_le_float(sweep.intensity.empty() ? 0.0f : sweep.intensity[i], out);
  }
  write_file_atomic(bin, out);
}

}  // namespace insalign::io
