// Surveyed fiducial points, one per line, '#' comments:
//   "id x y z" in the pose file's world frame (metres), or
//   after a first line "# wgs84": "id lat_deg lon_deg ellipsoidal_height_m", placed in the same
//   local ENU frame as the INS (CONVENTIONS.md), so only a geodetic INS source can use them.
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "core/dataset.hpp"
#include "core/geodesy.hpp"

namespace insalign::io {

/// World-frame fiducials. A "# wgs84" file is an InputError here (its numbers are not x y z).
/// Throws InputError(file, "line N", what) on a malformed line or a duplicate id.
std::vector<Fiducial> read_fiducials(const std::filesystem::path& path);

/// Whether a fiducial file's first line is the "# wgs84" marker.
bool is_wgs84_fiducial_text(std::string_view text);

/// Fiducials for a dataset, either kind: geodetic ones placed in `enu` (InputError naming
/// `ins_source` when there is none: the INS source is not geodetic), then recentred by
/// world_origin_m like the poses.
std::vector<Fiducial> read_dataset_fiducials(const std::filesystem::path& path, const std::optional<LocalEnu>& enu,
                                             const Vec3& world_origin_m, const std::string& ins_source);

void write_fiducials(const std::filesystem::path& path, const std::vector<Fiducial>& fiducials);
/// "# wgs84" then "id lat lon h" of each world point placed through `enu` (after adding world_origin_m).
void write_geodetic_fiducials(const std::filesystem::path& path, const std::vector<Fiducial>& fiducials,
                              const LocalEnu& enu, const Vec3& world_origin_m = Vec3::Zero());

}  // namespace insalign::io
