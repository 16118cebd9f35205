// The OpenCalib extrinsic JSON: one top-level key whose param.sensor_calib.data is the 4x4
// row-major T_lidar_ins ("gnss to lidar"), the inverse of the T_ins_lidar the tool estimates.
#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
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

/// An extrinsic from any of the JSON files insalign reads: a result's extrinsic.json or a
/// simulated ground_truth.json ("T_ins_lidar", optional "time_offset_s"), or an OpenCalib JSON
/// (T_lidar_ins). The one reader of extrinsic.json. Throws InputError naming the file.
struct ExtrinsicFile {
  Iso3 T_ins_lidar = Iso3::Identity();
  std::optional<double> time_offset_s;
  bool opencalib = false;  ///< read from the OpenCalib shape
};
ExtrinsicFile read_extrinsic_file(const std::filesystem::path& path);

}  // namespace insalign::io
