#include "inslog/sbet.hpp"

#include <fmt/format.h>

#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <stdexcept>

#include "core/errors.hpp"
#include "inslog/attitude.hpp"
#include "inslog/gps_time.hpp"
#include "files/read_file.hpp"

namespace insalign::io {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kMaxSecondsOfWeek = 2 * kSecondsPerGpsWeek;  // POSPac keeps counting past the week's end

double le_double(const char* p) {
  std::uint64_t bits = 0;
  std::memcpy(&bits, p, 8);
  if constexpr (std::endian::native == std::endian::big) bits = __builtin_bswap64(bits);
  return std::bit_cast<double>(bits);
}

void put_le_double(double v, char* p) {
  std::uint64_t bits = std::bit_cast<std::uint64_t>(v);
  if constexpr (std::endian::native == std::endian::big) bits = __builtin_bswap64(bits);
  std::memcpy(p, &bits, 8);
}

// Why a record cannot be an SBET record; empty if it can.
std::string implausible(const SbetRecord& r) {
  const double used[] = {r.time_sow_s, r.lat_rad, r.lon_rad, r.height_m, r.roll_rad, r.pitch_rad,
                         r.platform_heading_rad, r.wander_rad};
  for (const double v : used) {
    if (!std::isfinite(v)) return "a time, position or attitude value is not a finite number";
  }
  if (r.time_sow_s < 0.0 || r.time_sow_s > kMaxSecondsOfWeek) return fmt::format("time {} s is not GPS seconds of week", r.time_sow_s);
  if (std::abs(r.lat_rad) > kPi / 2) return fmt::format("latitude {} rad is beyond +-pi/2", r.lat_rad);
  if (std::abs(r.lon_rad) > 2 * kPi) return fmt::format("longitude {} rad is beyond +-2 pi", r.lon_rad);
  if (std::abs(r.height_m) > 1e5) return fmt::format("height {} m is more than 100 km from the ellipsoid", r.height_m);
  for (const double a : {r.roll_rad, r.pitch_rad, r.platform_heading_rad, r.wander_rad}) {
    if (std::abs(a) > 4 * kPi) return fmt::format("an angle of {} rad: angles are radians within +-4 pi", a);
  }
  return {};
}

std::string byte_at(std::size_t offset) { return "byte " + std::to_string(offset); }

InsRecord to_record(const SbetRecord& r, int week, std::size_t offset) {
  InsRecord out;
  out.t_s = gps_to_unix(week, r.time_sow_s);
  out.lat_deg = r.lat_rad * kDegPerRad;
  out.lon_deg = r.lon_rad * kDegPerRad;
  out.height_m = r.height_m;
  out.R_world_ins = R_enu_ins_sbet(r.roll_rad * kDegPerRad, r.pitch_rad * kDegPerRad,
                                   r.platform_heading_rad * kDegPerRad, r.wander_rad * kDegPerRad);
  out.location = byte_at(offset);
  return out;
}

void describe(InsTrack& track, int week, double hint_unix_s) {
  track.format = "POSPac SBET (17 float64 per record)";
  track.time_base = fmt::format("GPS seconds of week {} (inferred from the LiDAR clock: the week nearest to its "
                                "start, {} UTC), converted to UNIX (GPS - UTC = {} s)",
                                week, format_utc(hint_unix_s, 0), gps_minus_utc_s(track.records.front().t_s));
  track.body_frame = "SBET body frame (x forward, y right, z down; true heading = platform heading - wander angle)";
  track.height_datum = "ellipsoidal (the SBET's processing datum, taken as WGS-84)";
  track.world_frame = "local ENU at the first fix";
  track.geodetic = true;
}

}  // namespace

SbetRecord sbet_record_at(std::string_view bytes, std::size_t i) {
  double v[17];
  const char* p = bytes.data() + i * kSbetRecordBytes;
  for (int k = 0; k < 17; ++k) v[k] = le_double(p + 8 * k);
  SbetRecord r;
  std::memcpy(&r, v, sizeof r);
  return r;
}

std::array<char, kSbetRecordBytes> sbet_record_bytes(const SbetRecord& r) {
  double v[17];
  std::memcpy(v, &r, sizeof r);
  std::array<char, kSbetRecordBytes> out{};
  for (int k = 0; k < 17; ++k) put_le_double(v[k], out.data() + 8 * k);
  return out;
}

bool looks_like_sbet(std::string_view bytes) {
  const std::size_t n = std::min<std::size_t>(bytes.size() / kSbetRecordBytes, 3);
  if (n == 0) return false;
  double previous_t = -1.0;
  for (std::size_t i = 0; i < n; ++i) {
    const SbetRecord r = sbet_record_at(bytes, i);
    if (!implausible(r).empty() || (r.lat_rad == 0.0 && r.lon_rad == 0.0)) return false;
    if (i > 0 && !(r.time_sow_s > previous_t && r.time_sow_s < previous_t + 60.0)) return false;
    previous_t = r.time_sow_s;
  }
  return true;
}

InsTrack parse_sbet(std::string_view bytes, const std::string& file, std::optional<double> hint_unix_s) {
  if (bytes.size() % kSbetRecordBytes != 0) {
    const std::size_t whole = bytes.size() / kSbetRecordBytes;
    throw InputError(file, byte_at(whole * kSbetRecordBytes),
                     fmt::format("size {} bytes is not a multiple of 136 (17 float64 per SBET record): {} whole records "
                                 "and {} bytes of a cut-short one",
                                 bytes.size(), whole, bytes.size() % kSbetRecordBytes));
  }
  if (bytes.empty()) throw InputError(file, "", "empty SBET file");
  if (!hint_unix_s) {
    throw InputError(file, "", "an SBET stores GPS seconds of week without the week: the LiDAR's time is needed to "
                               "infer it (read the SBET together with the LiDAR data)");
  }
  InsTrack track;
  track.source = file;
  const std::size_t n = bytes.size() / kSbetRecordBytes;
  const int week = nearest_gps_week(sbet_record_at(bytes, 0).time_sow_s, *hint_unix_s);
  track.records.reserve(n);
  for (std::size_t i = 0; i < n; ++i) {
    const std::size_t offset = i * kSbetRecordBytes;
    const SbetRecord r = sbet_record_at(bytes, i);
    if (const std::string why = implausible(r); !why.empty()) throw InputError(file, byte_at(offset), why);
    InsRecord rec = to_record(r, week, offset);
    if (!track.records.empty() && !(rec.t_s > track.records.back().t_s)) {
      throw InputError(file, byte_at(offset),
                       fmt::format("time {:.6f} s of week does not come after the previous record's ({}): {}",
                                   r.time_sow_s, track.records.back().location,
                                   rec.t_s == track.records.back().t_s ? "a repeated time" : "time goes backwards"));
    }
    track.records.push_back(std::move(rec));
  }
  describe(track, week, *hint_unix_s);
  const double gap_days = std::abs(track.records.front().t_s - *hint_unix_s) / 86400.0;
  if (gap_days > 1.0) {
    track.warnings.push_back(fmt::format("the SBET starts {:.1f} days from the LiDAR clock: if its times are seconds of "
                                         "the day rather than of the GPS week, the week inferred is wrong", gap_days));
  }
  return track;
}

InsTrack read_sbet(const std::filesystem::path& path, std::optional<double> lidar_time_hint_unix_s) {
  return parse_sbet(read_file(path), path.string(), lidar_time_hint_unix_s);
}

}  // namespace insalign::io
