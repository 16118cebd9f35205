#include "files/extrinsic_json.hpp"

#include <cmath>
#include <fmt/format.h>
#include <fstream>
#include <sstream>

#include "core/errors.hpp"
#include "files/atomic_file.hpp"
#include "files/read_file.hpp"

namespace insalign::io {

namespace {

constexpr double kOrthonormalTolerance = 1e-3;  // OpenCalib files store 7 decimals; more is a wrong matrix
constexpr double kLastRowTolerance = 1e-6;


nlohmann::json parse_json(const std::filesystem::path& path) {
  const std::string text = read_file(path);
  try {
    return nlohmann::json::parse(text);
  } catch (const nlohmann::json::parse_error& e) {
    // e.byte is 1-based; report the line too, people open the file in an editor.
    const std::size_t byte = e.byte > 0 ? e.byte - 1 : 0;
    const std::size_t line = 1 + static_cast<std::size_t>(
                                     std::count(text.begin(), text.begin() + static_cast<std::ptrdiff_t>(
                                                                                 std::min(byte, text.size())),
                                                '\n'));
    throw InputError(path.string(), fmt::format("line {} (byte {})", line, byte), "malformed JSON");
  }
}

std::string target_from_key(const std::string& key) {
  const std::string prefix = "gnss-to-", suffix = "-extrinsic";
  if (key.size() > prefix.size() + suffix.size() && key.rfind(prefix, 0) == 0 &&
      key.compare(key.size() - suffix.size(), suffix.size(), suffix) == 0) {
    return key.substr(prefix.size(), key.size() - prefix.size() - suffix.size());
  }
  return "lidar";
}

}  // namespace

nlohmann::json transform_to_json(const Iso3& T) {
  const Eigen::Matrix4d M = T.matrix();
  nlohmann::json rows = nlohmann::json::array();
  for (int r = 0; r < 4; ++r) {
    nlohmann::json row = nlohmann::json::array();
    for (int c = 0; c < 4; ++c) row.push_back(M(r, c));
    rows.push_back(row);
  }
  return rows;
}

Iso3 transform_from_json(const nlohmann::json& j, const std::string& file_for_errors) {
  const std::string& file = file_for_errors;
  Eigen::Matrix4d M;
  // Either 4 rows of 4 numbers or a flat row-major array of 16.
  if (j.is_array() && j.size() == 16) {
    for (int i = 0; i < 16; ++i) {
      if (!j[i].is_number()) throw InputError(file, "", "transform element " + std::to_string(i) + " is not a number");
      M(i / 4, i % 4) = j[i].get<double>();
    }
  } else if (j.is_array() && j.size() == 4) {
    for (int r = 0; r < 4; ++r) {
      const auto& row = j[r];
      if (!row.is_array() || row.size() != 4) {
        throw InputError(file, "", "transform row " + std::to_string(r) + " is not an array of 4 numbers");
      }
      for (int c = 0; c < 4; ++c) {
        if (!row[c].is_number()) {
          throw InputError(file, "", fmt::format("transform element [{}][{}] is not a number", r, c));
        }
        M(r, c) = row[c].get<double>();
      }
    }
  } else {
    throw InputError(file, "", "a transform must be a 4x4 array of arrays (row-major)");
  }
  if (!M.allFinite()) throw InputError(file, "", "transform has a non-finite element");
  const double last_row_error = (M.row(3) - Eigen::RowVector4d(0, 0, 0, 1)).cwiseAbs().maxCoeff();
  if (!(last_row_error <= kLastRowTolerance)) throw InputError(file, "", "transform's last row is not [0, 0, 0, 1]");
  const Mat3 R = M.topLeftCorner<3, 3>();
  const double deviation = (R.transpose() * R - Mat3::Identity()).cwiseAbs().maxCoeff();
  if (!(deviation <= kOrthonormalTolerance)) {
    throw InputError(file, "", fmt::format("rotation is not orthonormal (|R^T R - I| = {:.3g}, allowed {})",
                                           deviation, kOrthonormalTolerance));
  }
  if (R.determinant() < 0) throw InputError(file, "", "rotation has determinant -1 (a reflection)");
  Iso3 T = Iso3::Identity();
  T.linear() = nearest_rotation(R);
  T.translation() = M.topRightCorner<3, 1>();
  return T;
}

Iso3 read_opencalib_extrinsic(const std::filesystem::path& path) {
  const std::string file = path.string();
  const nlohmann::json j = parse_json(path);
  if (!j.is_object() || j.empty()) throw InputError(file, "", "expected a JSON object with one extrinsic entry");
  for (const auto& [key, entry] : j.items()) {
    if (!entry.is_object() || !entry.contains("param")) continue;
    const auto& param = entry["param"];
    if (!param.is_object() || !param.contains("sensor_calib")) continue;
    const auto& calib = param["sensor_calib"];
    if (!calib.is_object() || !calib.contains("data")) continue;
    const Iso3 T_lidar_ins = transform_from_json(calib["data"], file + " (" + key + ".param.sensor_calib.data)");
    return T_lidar_ins.inverse();
  }
  throw InputError(file, "", "no entry with param.sensor_calib.data (not an OpenCalib extrinsic file)");
}

void write_opencalib_extrinsic(const std::filesystem::path& path, const Iso3& T_ins_lidar, const std::string& key) {
  nlohmann::json calib = {{"data", transform_to_json(T_ins_lidar.inverse())},
                          {"continuous", true},
                          {"rows", 4},
                          {"cols", 4},
                          {"type", 6}};
  nlohmann::json entry = {{"param_type", "extrinsic"},
                          {"sensor_name", "gnss"},
                          {"target_sensor_name", target_from_key(key)},
                          {"device_type", "relational"},
                          {"param", {{"sensor_calib", calib}, {"time_lag", 0}}}};
  // nlohmann::json prints doubles in the shortest form that reads back exactly.
  write_file_atomic(path, nlohmann::json{{key, entry}}.dump(4) + "\n");
}

}  // namespace insalign::io

namespace insalign::io {

ExtrinsicFile read_extrinsic_file(const std::filesystem::path& path) {
  const nlohmann::json j = parse_json(path);
  ExtrinsicFile out;
  if (!j.is_object() || !j.contains("T_ins_lidar")) {
    out.T_ins_lidar = read_opencalib_extrinsic(path);
    out.opencalib = true;
    return out;
  }
  out.T_ins_lidar = transform_from_json(j.at("T_ins_lidar"), path.string());
  if (j.contains("time_offset_s")) {
    const auto& t = j.at("time_offset_s");
    if (!t.is_number() || !std::isfinite(t.get<double>()))
      throw InputError(path.string(), "", "\"time_offset_s\" is not a finite number");
    out.time_offset_s = t.get<double>();
  }
  return out;
}

}  // namespace insalign::io
