// INS pose files: OpenCalib per-frame lines ("<frame-name> r00 r01 r02 tx r10 ... tz") and TUM
// ("t x y z qx qy qz qw"), both T_world_ins.
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "core/geometry.hpp"
#include "core/pose_stream.hpp"

namespace insalign::io {

enum class PoseFormat { kOpenCalib, kTum };

struct PoseFile {
  PoseFormat format = PoseFormat::kOpenCalib;
  std::vector<std::string> frame_names;  ///< OpenCalib only, one per pose (empty for TUM)
  std::vector<double> t_s;               ///< per pose; NaN where an OpenCalib name is not a time
  std::vector<Iso3> T_world_ins;
  std::vector<std::size_t> line;         ///< 1-based source line of each pose (for messages)
  std::size_t reorthonormalised = 0;     ///< rotations off by more than 1e-6 (more than print rounding) but within 1e-3, fixed
};

/// Reads either format (detected from the first data line: a numeric first token followed by
/// exactly 7 numbers is TUM, 12 numbers is OpenCalib). Rotations must be orthonormal within 1e-3
/// with det +1; smaller errors are re-orthonormalised. '#' starts a comment; blank lines skipped.
/// Throws InputError(file, "line N", what).
PoseFile read_pose_file(const std::filesystem::path& path);

void write_opencalib_poses(const std::filesystem::path& path, const std::vector<std::string>& frame_names,
                           const std::vector<Iso3>& T_world_ins);
void write_tum_poses(const std::filesystem::path& path, const std::vector<StampedPose>& poses);

/// Time in seconds encoded in a frame name: a decimal number ("1635236489.468"), an integer read
/// as ns / us / ms / s by its digit count (19 / 16 / 13 / 10), or "YYYY-MM-DD-HH-MM-SS-mmm"
/// (taken as UTC; load_dataset aligns it to the LiDAR clock). nullopt if none of these.
std::optional<double> time_from_frame_name(std::string_view name);

}  // namespace insalign::io
