// The OpenCalib extrinsic JSON: one top-level key whose param.sensor_calib.data is the 4x4
// row-major T_lidar_ins ("gnss to lidar"), the inverse of the T_ins_lidar the tool estimates.
#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>

#include "core/geometry.hpp"

namespace insalign::io {

/// Returns T_ins_lidar (the inverse of the stored matrix). Throws InputError naming the file.
Iso3 read_opencalib_extrinsic(const std::filesystem::path& path);

/// Writes T_lidar_ins = T_ins_lidar^-1 in the OpenCalib shape, full double precision, atomically.
void write_opencalib_extrinsic(const std::filesystem::path& path, const Iso3& T_ins_lidar,
                               const std::string& key = "gnss-to-top_center_lidar-extrinsic");

/// A transform as a 4x4 row-major array of arrays (full double precision when dumped).
nlohmann::json transform_to_json(const Iso3& T);

/// Inverse of transform_to_json; checks shape, finiteness, last row and the rotation
/// (orthonormal within 1e-3, det +1, re-orthonormalised). Throws InputError(file_for_errors, ...).
Iso3 transform_from_json(const nlohmann::json& j, const std::string& file_for_errors);

}  // namespace insalign::io
