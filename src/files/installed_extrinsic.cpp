#include "files/installed_extrinsic.hpp"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>

#include "core/errors.hpp"
#include "files/extrinsic_json.hpp"
#include "files/formats.hpp"
#include "files/read_file.hpp"

namespace insalign::io {
namespace {

using nlohmann::json;

std::string line_at(std::string_view text, std::size_t byte) {
  byte = std::min(byte, text.size());
  return "line " + std::to_string(1 + std::count(text.begin(), text.begin() + static_cast<std::ptrdiff_t>(byte), '\n'));
}

// {"T_ins_lidar": 4x4, "time_offset_s": optional}: extrinsic.json, or one LiDAR of rig.json.
InstalledExtrinsic one_extrinsic(const json& j, const std::string& file, const std::string& where, const std::string& name,
                                 const char* format) {
  if (!j.is_object() || !j.contains("T_ins_lidar"))
    throw InputError(file, where, "expected an object with \"T_ins_lidar\"");
  InstalledExtrinsic e{name, transform_from_json(j.at("T_ins_lidar"), file + (where.empty() ? "" : " (" + where + ")")), 0.0,
                       format};
  if (j.contains("time_offset_s")) {
    const json& t = j.at("time_offset_s");
    if (!t.is_number() || !std::isfinite(t.get<double>()))
      throw InputError(file, where.empty() ? "time_offset_s" : where + ".time_offset_s", "not a finite number");
    e.time_offset_s = t.get<double>();
  }
  return e;
}

std::vector<InstalledExtrinsic> from_json(std::string_view text, const std::string& file) {
  json j;
  try {
    j = json::parse(text);
  } catch (const json::parse_error& e) {
    throw InputError(file, line_at(text, e.byte > 0 ? e.byte - 1 : 0), "malformed JSON");
  }
  if (!j.is_object()) throw InputError(file, "", "expected a JSON object (extrinsic.json, rig.json or OpenCalib)");
  if (j.contains("lidars")) {  // rig.json; only the extrinsic and the time offset are needed here
    const json& lidars = j.at("lidars");
    if (!lidars.is_object() || lidars.empty()) throw InputError(file, "lidars", "expected an object with one key per LiDAR");
    std::vector<InstalledExtrinsic> out;
    for (const auto& [name, l] : lidars.items()) out.push_back(one_extrinsic(l, file, "lidars." + name, name, "rig.json"));
    return out;
  }
  if (j.contains("T_ins_lidar")) return {one_extrinsic(j, file, "", "", "extrinsic.json")};
  for (const auto& [key, entry] : j.items()) {  // OpenCalib: {key: {param: {sensor_calib: {data: T_lidar_ins}}}}
    if (!entry.is_object() || !entry.contains("param") || !entry["param"].is_object()) continue;
    const json& param = entry["param"];
    if (!param.contains("sensor_calib") || !param["sensor_calib"].is_object() || !param["sensor_calib"].contains("data"))
      continue;
    const Iso3 T_lidar_ins = transform_from_json(param["sensor_calib"]["data"], file + " (" + key + ".param.sensor_calib.data)");
    return {{"", T_lidar_ins.inverse(), 0.0, "opencalib"}};
  }
  throw InputError(file, "", "JSON without \"T_ins_lidar\", \"lidars\" or an OpenCalib param.sensor_calib.data");
}

// A URDF with several fixed joints (a rig's): one extrinsic per joint, named by its child link.
std::vector<InstalledExtrinsic> from_urdf(std::string_view text, const std::string& file) {
  std::vector<std::size_t> starts;
  for (std::size_t at = text.find("<joint"); at != std::string_view::npos; at = text.find("<joint", at + 1))
    starts.push_back(at);
  if (starts.size() <= 1) {
    const ReadTransform t = parse_urdf(text, file);
    return {{t.names.child, t.T_parent_child, 0.0, "urdf"}};
  }
  std::vector<InstalledExtrinsic> out;
  for (std::size_t k = 0; k < starts.size(); ++k) {
    const std::size_t end = k + 1 < starts.size() ? starts[k + 1] : text.size();
    const ReadTransform t = parse_urdf(text.substr(starts[k], end - starts[k]), file + " (" + line_at(text, starts[k]) + ")");
    out.push_back({t.names.child, t.T_parent_child, 0.0, "urdf"});
  }
  return out;
}

}  // namespace

std::vector<InstalledExtrinsic> parse_installed_extrinsics(std::string_view text, const std::string& file) {
  const std::size_t first = text.find_first_not_of(" \t\r\n");
  if (first == std::string_view::npos) throw InputError(file, "", "empty file: expected an extrinsic");
  if (text[first] == '{') return from_json(text, file);
  if (text.find("<origin") != std::string_view::npos || text.find("<robot") != std::string_view::npos)
    return from_urdf(text, file);
  if (text.find("static_transform_publisher") != std::string_view::npos) {
    const ReadTransform t = parse_ros2_static_tf(text, file);
    return {{t.names.child, t.T_parent_child, 0.0, "ros2"}};
  }
  const bool kitti = text.compare(first, 2, "R:") == 0 || text.find("\nR:") != std::string_view::npos ||
                     text.find("calib_time:") != std::string_view::npos;
  if (kitti) return {{"", parse_kitti_imu_to_velo(text, file).T_parent_child, 0.0, "kitti"}};
  if (text.find(':') != std::string_view::npos) {
    const ReadTransform t = parse_autoware_yaml(text, file);
    return {{t.names.child, t.T_parent_child, 0.0, "autoware"}};
  }
  throw InputError(file, "line 1",
                   "not an extrinsic insalign reads (extrinsic.json, OpenCalib JSON, rig.json, URDF/xacro, "
                   "static_transform_publisher script, Autoware YAML, KITTI calib_imu_to_velo.txt)");
}

std::vector<InstalledExtrinsic> read_installed_extrinsics(const std::filesystem::path& path) {
  return parse_installed_extrinsics(read_file(path), path.string());
}

Iso3 read_init_extrinsic(const std::filesystem::path& path) {
  const std::vector<InstalledExtrinsic> all = read_installed_extrinsics(path);
  if (all.empty()) throw InputError(path.string(), "", "holds no extrinsic");
  if (all.size() > 1)
    throw InputError(path.string(), "", fmt::format("holds {} extrinsics (a rig's {}): give one --init per LiDAR, "
                                                    "each a file of one extrinsic", all.size(), all.front().format));
  return all.front().T_ins_lidar;
}

}  // namespace insalign::io
