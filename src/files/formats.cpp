#include "files/formats.hpp"

#include <fmt/chrono.h>
#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <map>
#include <optional>
#include <regex>
#include <sstream>

#include "core/errors.hpp"
#include "files/atomic_file.hpp"

namespace insalign::io {
namespace {

// 17 significant digits: a double printed this way reads back bit-identical. (+ 0.0 turns -0 into 0.)
std::string num(double v) { return fmt::format("{:.17g}", v + 0.0); }

std::string line_of(std::string_view text, std::size_t offset) {
  const auto lines = std::count(text.begin(), text.begin() + std::min(offset, text.size()), '\n');
  return "line " + std::to_string(lines + 1);
}

double parse_number(const std::string& token, const std::string& file, const std::string& where,
                    const std::string& what) {
  const char* begin = token.c_str();
  char* end = nullptr;
  const double v = std::strtod(begin, &end);
  if (token.empty() || end != begin + token.size() || !std::isfinite(v)) {
    throw InputError(file, where, what + ": '" + token + "' is not a finite number");
  }
  return v;
}

std::vector<std::string> split_ws(const std::string& s) {
  std::istringstream in(s);
  std::vector<std::string> out;
  for (std::string tok; in >> tok;) out.push_back(tok);
  return out;
}

Iso3 from_xyz_rpy(const Vec3& xyz_m, const Vec3& rpy_rad) {
  Iso3 T = Iso3::Identity();
  T.linear() = rotation_from_rpy(rpy_rad);
  T.translation() = xyz_m;
  return T;
}

// The value of attribute `name` inside one XML tag's text, if present.
std::optional<std::string> xml_attribute(const std::string& tag, const std::string& name) {
  const std::regex re("\\b" + name + "\\s*=\\s*[\"']([^\"']*)[\"']");
  std::smatch m;
  if (!std::regex_search(tag, m, re)) return std::nullopt;
  return m[1].str();
}

// The first `<element ...>` tag's text and its offset, if present.
std::optional<std::pair<std::string, std::size_t>> xml_tag(std::string_view text, const std::string& element) {
  const std::string t(text);
  const std::regex re("<\\s*" + element + "\\b[^>]*>");
  std::smatch m;
  if (!std::regex_search(t, m, re)) return std::nullopt;
  return std::make_pair(m[0].str(), static_cast<std::size_t>(m.position(0)));
}

Vec3 three_numbers(const std::string& value, const std::string& file, const std::string& where,
                   const std::string& what) {
  const auto tokens = split_ws(value);
  if (tokens.size() != 3) throw InputError(file, where, what + " needs 3 numbers, has " + std::to_string(tokens.size()));
  return {parse_number(tokens[0], file, where, what), parse_number(tokens[1], file, where, what),
          parse_number(tokens[2], file, where, what)};
}

}  // namespace

std::string format_urdf(const Iso3& T_ins_lidar, const FrameNames& names) {
  const Vec3 t = T_ins_lidar.translation();
  const Vec3 rpy = rpy_from_rotation(T_ins_lidar.linear());
  return fmt::format(
      "<?xml version=\"1.0\"?>\n"
      "<!-- LiDAR extrinsic from insalign: the pose of link \"{child}\" in link \"{parent}\" (T_{parent}_{child}).\n"
      "     xyz in metres, rpy in radians (URDF fixed-axis X-Y-Z = ZYX yaw-pitch-roll).\n"
      "     Copy the joint into your robot description. -->\n"
      "<robot name=\"insalign_extrinsic\" xmlns:xacro=\"http://www.ros.org/wiki/xacro\">\n"
      "  <joint name=\"{parent}_to_{child}\" type=\"fixed\">\n"
      "    <parent link=\"{parent}\"/>\n"
      "    <child link=\"{child}\"/>\n"
      "    <origin xyz=\"{x} {y} {z}\" rpy=\"{roll} {pitch} {yaw}\"/>\n"
      "  </joint>\n"
      "</robot>\n",
      fmt::arg("parent", names.parent), fmt::arg("child", names.child), fmt::arg("x", num(t.x())),
      fmt::arg("y", num(t.y())), fmt::arg("z", num(t.z())), fmt::arg("roll", num(rpy.x())),
      fmt::arg("pitch", num(rpy.y())), fmt::arg("yaw", num(rpy.z())));
}

ReadTransform parse_urdf(std::string_view text, const std::string& file) {
  const auto origin = xml_tag(text, "origin");
  if (!origin) throw InputError(file, "", "no <origin .../> element");
  const std::string where = line_of(text, origin->second);
  Vec3 xyz = Vec3::Zero(), rpy = Vec3::Zero();  // URDF defaults for missing attributes
  if (const auto v = xml_attribute(origin->first, "xyz")) xyz = three_numbers(*v, file, where, "origin xyz");
  if (const auto v = xml_attribute(origin->first, "rpy")) rpy = three_numbers(*v, file, where, "origin rpy");
  ReadTransform out;
  out.T_parent_child = from_xyz_rpy(xyz, rpy);
  out.names.parent.clear();
  out.names.child.clear();
  if (const auto tag = xml_tag(text, "parent")) out.names.parent = xml_attribute(tag->first, "link").value_or("");
  if (const auto tag = xml_tag(text, "child")) out.names.child = xml_attribute(tag->first, "link").value_or("");
  return out;
}

std::string format_ros2_static_tf(const Iso3& T_ins_lidar, const FrameNames& names) {
  const Vec3 t = T_ins_lidar.translation();
  const Vec3 rpy = rpy_from_rotation(T_ins_lidar.linear());
  return fmt::format(
      "#!/bin/sh\n"
      "# LiDAR extrinsic from insalign: publishes T_{parent}_{child} (metres, radians) on /tf_static.\n"
      "exec ros2 run tf2_ros static_transform_publisher \\\n"
      "  --x {x} --y {y} --z {z} \\\n"
      "  --roll {roll} --pitch {pitch} --yaw {yaw} \\\n"
      "  --frame-id {parent} --child-frame-id {child}\n",
      fmt::arg("parent", names.parent), fmt::arg("child", names.child), fmt::arg("x", num(t.x())),
      fmt::arg("y", num(t.y())), fmt::arg("z", num(t.z())), fmt::arg("roll", num(rpy.x())),
      fmt::arg("pitch", num(rpy.y())), fmt::arg("yaw", num(rpy.z())));
}

ReadTransform parse_ros2_static_tf(std::string_view text, const std::string& file) {
  // Tokens with their line numbers, comments and line continuations dropped.
  std::vector<std::pair<std::string, int>> tokens;
  std::istringstream in{std::string(text)};
  int line_no = 0;
  for (std::string line; std::getline(in, line);) {
    ++line_no;
    const auto hash = line.find('#');
    if (hash != std::string::npos) line.resize(hash);
    for (auto& tok : split_ws(line)) {
      if (tok != "\\") tokens.emplace_back(tok, line_no);
    }
  }
  std::size_t i = 0;
  while (i < tokens.size() && tokens[i].first != "static_transform_publisher") ++i;
  if (i == tokens.size()) throw InputError(file, "", "no 'static_transform_publisher' command");
  std::map<std::string, std::pair<std::string, int>> options;
  for (++i; i < tokens.size(); ++i) {
    const auto& [tok, line] = tokens[i];
    if (tok.rfind("--", 0) != 0) {
      throw InputError(file, "line " + std::to_string(line),
                       "unexpected argument '" + tok + "' (only the --x .. --child-frame-id form is read)");
    }
    const auto eq = tok.find('=');
    if (eq != std::string::npos) {
      options[tok.substr(2, eq - 2)] = {tok.substr(eq + 1), line};
    } else if (i + 1 < tokens.size()) {
      options[tok.substr(2)] = tokens[i + 1];
      ++i;
    } else {
      throw InputError(file, "line " + std::to_string(line), "option " + tok + " has no value");
    }
  }
  auto value = [&](const std::string& key, double fallback) {
    const auto it = options.find(key);
    if (it == options.end()) return fallback;  // the publisher's own default is 0
    return parse_number(it->second.first, file, "line " + std::to_string(it->second.second), "--" + key);
  };
  for (const char* q : {"qx", "qy", "qz", "qw"}) {
    if (options.count(q) != 0) throw InputError(file, "", "quaternion arguments are not read; use --roll/--pitch/--yaw");
  }
  ReadTransform out;
  out.T_parent_child = from_xyz_rpy(Vec3(value("x", 0), value("y", 0), value("z", 0)),
                                    Vec3(value("roll", 0), value("pitch", 0), value("yaw", 0)));
  out.names.parent = options.count("frame-id") ? options["frame-id"].first : "";
  out.names.child = options.count("child-frame-id") ? options["child-frame-id"].first : "";
  return out;
}

std::string format_autoware_yaml(const Iso3& T_ins_lidar, const FrameNames& names) {
  const Vec3 t = T_ins_lidar.translation();
  const Vec3 rpy = rpy_from_rotation(T_ins_lidar.linear());
  return fmt::format(
      "# LiDAR extrinsic from insalign: pose of {child} in {parent} (metres; roll, pitch, yaw in radians,\n"
      "# R = Rz(yaw) Ry(pitch) Rx(roll)), in the layout of Autoware's sensor_kit_calibration.yaml.\n"
      "{parent}:\n"
      "  {child}:\n"
      "    x: {x}\n"
      "    y: {y}\n"
      "    z: {z}\n"
      "    roll: {roll}\n"
      "    pitch: {pitch}\n"
      "    yaw: {yaw}\n",
      fmt::arg("parent", names.parent), fmt::arg("child", names.child), fmt::arg("x", num(t.x())),
      fmt::arg("y", num(t.y())), fmt::arg("z", num(t.z())), fmt::arg("roll", num(rpy.x())),
      fmt::arg("pitch", num(rpy.y())), fmt::arg("yaw", num(rpy.z())));
}

ReadTransform parse_autoware_yaml(std::string_view text, const std::string& file) {
  YAML::Node root;
  try {
    root = YAML::Load(std::string(text));
  } catch (const YAML::Exception& e) {
    throw InputError(file, "line " + std::to_string(e.mark.line + 1), e.msg);
  }
  auto where = [](const YAML::Node& n) { return "line " + std::to_string(n.Mark().line + 1); };
  if (!root.IsMap() || root.size() != 1) throw InputError(file, "", "expected one parent frame key at the top");
  const auto parent = *root.begin();
  if (!parent.second.IsMap() || parent.second.size() != 1) {
    throw InputError(file, where(parent.first), "expected one child frame key under '" + parent.first.Scalar() + "'");
  }
  const auto child = *parent.second.begin();
  if (!child.second.IsMap()) throw InputError(file, where(child.first), "expected x, y, z, roll, pitch, yaw");
  auto get = [&](const char* key) {
    const YAML::Node n = child.second[key];
    if (!n) throw InputError(file, where(child.first), std::string("missing '") + key + "'");
    if (!n.IsScalar()) throw InputError(file, where(n), std::string("'") + key + "' is not a number");
    return parse_number(n.Scalar(), file, where(n), key);
  };
  ReadTransform out;
  out.T_parent_child = from_xyz_rpy(Vec3(get("x"), get("y"), get("z")), Vec3(get("roll"), get("pitch"), get("yaw")));
  out.names.parent = parent.first.Scalar();
  out.names.child = child.first.Scalar();
  return out;
}

std::string format_kitti_imu_to_velo(const Iso3& T_ins_lidar) {
  const Iso3 T_lidar_ins = T_ins_lidar.inverse();
  const Mat3 R = T_lidar_ins.linear();
  const Vec3 t = T_lidar_ins.translation();
  const auto now = std::chrono::floor<std::chrono::seconds>(std::chrono::system_clock::now());
  std::string out = fmt::format("calib_time: {:%d-%b-%Y %H:%M:%S}\nR:", now);
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) out.append(" ").append(num(R(r, c)));
  out += "\nT:";
  for (int r = 0; r < 3; ++r) out.append(" ").append(num(t(r)));
  out += "\n";
  return out;
}

ReadTransform parse_kitti_imu_to_velo(std::string_view text, const std::string& file) {
  std::optional<std::vector<double>> R_values, T_values;
  std::istringstream in{std::string(text)};
  int line_no = 0;
  for (std::string line; std::getline(in, line);) {
    ++line_no;
    const auto colon = line.find(':');
    if (colon == std::string::npos) continue;
    const std::string key = line.substr(0, colon);
    if (key != "R" && key != "T") continue;  // calib_time and any extra keys
    const std::string where = "line " + std::to_string(line_no);
    std::vector<double> values;
    for (const auto& tok : split_ws(line.substr(colon + 1))) values.push_back(parse_number(tok, file, where, key));
    const std::size_t want = key == "R" ? 9 : 3;
    if (values.size() != want) {
      throw InputError(file, where, key + " needs " + std::to_string(want) + " numbers, has " + std::to_string(values.size()));
    }
    (key == "R" ? R_values : T_values) = values;
  }
  if (!R_values) throw InputError(file, "", "no 'R:' line");
  if (!T_values) throw InputError(file, "", "no 'T:' line");
  Mat3 R;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) R(r, c) = (*R_values)[3 * r + c];
  if ((R * R.transpose() - Mat3::Identity()).norm() > 1e-6 || R.determinant() < 0) {
    throw InputError(file, "", "R is not a rotation matrix (not orthonormal with determinant +1)");
  }
  Iso3 T_lidar_ins = Iso3::Identity();
  T_lidar_ins.linear() = R;
  T_lidar_ins.translation() = Vec3((*T_values)[0], (*T_values)[1], (*T_values)[2]);
  ReadTransform out;
  out.T_parent_child = T_lidar_ins.inverse();
  out.names.parent.clear();
  out.names.child.clear();
  return out;
}

std::vector<std::filesystem::path> write_all_formats(const std::filesystem::path& out_dir, const Iso3& T_ins_lidar,
                                                     const FrameNames& names) {
  ensure_writable_dir(out_dir);
  const std::vector<std::pair<std::filesystem::path, std::string>> files = {
      {out_dir / kUrdfFile, format_urdf(T_ins_lidar, names)},
      {out_dir / kRos2File, format_ros2_static_tf(T_ins_lidar, names)},
      {out_dir / kAutowareFile, format_autoware_yaml(T_ins_lidar, names)},
      {out_dir / kKittiFile, format_kitti_imu_to_velo(T_ins_lidar)},
  };
  std::vector<std::filesystem::path> written;
  for (const auto& [path, content] : files) {
    write_file_atomic(path, content);
    written.push_back(path);
  }
  // The ROS 2 command is a runnable script.
  std::error_code ec;
  std::filesystem::permissions(out_dir / kRos2File,
                               std::filesystem::perms::owner_exec | std::filesystem::perms::group_exec |
                                   std::filesystem::perms::others_exec,
                               std::filesystem::perm_options::add, ec);
  return written;
}

}  // namespace insalign::io
