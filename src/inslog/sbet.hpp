// Applanix POSPac SBET ("smoothed best estimate of trajectory", sbet_*.out): headerless binary,
// 17 little-endian float64 per record (136 bytes), in this order: time (GPS seconds of week),
// latitude, longitude (rad), altitude (m, ellipsoidal), x, y, z velocity (m/s, wander frame), roll,
// pitch, platform heading, wander angle (rad), x, y, z body acceleration (m/s^2), x, y, z body
// angular rate (rad/s). The body frame is x forward, y right, z down; the true heading is platform
// heading - wander angle (inslog/attitude.hpp R_enu_ins_sbet).
//
// The file holds no week: read_sbet takes the week for which the first record's seconds lie nearest
// to the LiDAR's first stamp and says so in InsTrack::time_base.
#pragma once

#include <array>
#include <cstddef>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>

#include "inslog/ins_track.hpp"

namespace insalign::io {

inline constexpr std::size_t kSbetRecordBytes = 136;

/// One record, the fields in file order.
struct SbetRecord {
  double time_sow_s, lat_rad, lon_rad, height_m;
  double vx_mps, vy_mps, vz_mps;
  double roll_rad, pitch_rad, platform_heading_rad, wander_rad;
  double ax_mps2, ay_mps2, az_mps2;
  double wx_radps, wy_radps, wz_radps;
};
static_assert(sizeof(SbetRecord) == kSbetRecordBytes);

/// Record i of `bytes` (little-endian on any host). Requires (i + 1) * 136 <= bytes.size().
SbetRecord sbet_record_at(std::string_view bytes, std::size_t i);
/// The 136 little-endian bytes of `r`.
std::array<char, kSbetRecordBytes> sbet_record_bytes(const SbetRecord& r);

/// Reads the SBET into a geodetic InsTrack. Without `lidar_time_hint_unix_s` the week cannot be
/// known: InputError saying so. Throws InputError(file, "byte N", what) for a size that is not a
/// multiple of 136, a non-finite or out-of-range value, or a time that does not increase.
InsTrack read_sbet(const std::filesystem::path& path, std::optional<double> lidar_time_hint_unix_s);
InsTrack parse_sbet(std::string_view bytes, const std::string& file_for_errors,
                    std::optional<double> lidar_time_hint_unix_s);

/// True if the first records of `bytes` are plausible SBET records (time of week, latitude and
/// longitude in radians, a height within 100 km of the ellipsoid, angles within 4 pi), whatever the size.
bool looks_like_sbet(std::string_view bytes);

}  // namespace insalign::io
