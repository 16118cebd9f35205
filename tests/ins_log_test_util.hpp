// Shared by the INS log tests: scratch folders, a drive whose poses are known, and comparisons.
// The expected values here are built independently of src/inslog (own rotations, own CRC), so the
// readers are checked against a second code path, not against themselves.
#pragma once

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "cli_test_util.hpp"
#include "core/geometry.hpp"
#include "core/pose_stream.hpp"

namespace insalign::test {

/// A fresh folder `name` in this process's ScratchDir, removed at the process's exit (ctest runs
/// each test in a process of its own); helpers return paths in it, so it outlives their calls.
inline std::filesystem::path scratch_dir(const std::string& name) {
  static const insalign::testing::ScratchDir root("insalign-ins", "");
  const auto dir = root.path() / name;
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

inline void write_text(const std::filesystem::path& p, const std::string& text) {
  std::filesystem::create_directories(p.parent_path());
  std::ofstream out(p, std::ios::binary);
  out << text;
}

inline std::string read_text(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

/// NovAtel's CRC-32, bit by bit as NovAtel's manual prints it (no table): a second implementation.
inline std::uint32_t bitwise_novatel_crc(const std::string& s) {
  std::uint32_t crc = 0;
  for (const unsigned char byte : s) {
    std::uint32_t t = (crc ^ byte) & 0xFFu;
    for (int j = 0; j < 8; ++j) t = (t & 1u) ? (t >> 1) ^ 0xEDB88320u : t >> 1;
    crc = ((crc >> 8) & 0x00FFFFFFu) ^ t;
  }
  return crc;
}

/// A NovAtel record with its CRC: `content` is everything between the lead character and '*'.
inline std::string novatel_record_line(char lead, const std::string& content) {
  char crc[9];
  std::snprintf(crc, sizeof crc, "%08x", bitwise_novatel_crc(content));
  return std::string(1, lead) + content + "*" + crc + "\r\n";
}

/// Rotation about a unit axis by degrees (the test's own, not inslog/attitude.cpp's).
inline Mat3 axis_rot(int axis, double deg) {
  const double a = deg * M_PI / 180.0, c = std::cos(a), s = std::sin(a);
  Mat3 R = Mat3::Identity();
  const int i = (axis + 1) % 3, j = (axis + 2) % 3;
  R(i, i) = c, R(i, j) = -s, R(j, i) = s, R(j, j) = c;
  return R;
}

/// Body axes in ENU from first principles: forward/right/up unit vectors of a vehicle heading
/// `heading_cw_deg` clockwise from north with pitch (nose up +) and roll (right side down +).
struct VehicleAxes {
  Vec3 forward, right, up;
};
inline VehicleAxes vehicle_axes(double heading_cw_deg, double pitch_up_deg, double roll_right_down_deg) {
  const double h = heading_cw_deg * M_PI / 180.0;
  Vec3 f(std::sin(h), std::cos(h), 0.0), r(std::cos(h), -std::sin(h), 0.0), u = Vec3::UnitZ();
  // pitch: forward and up about the right axis (right-handed: nose up); then roll: right and up
  // about the new forward axis (right-handed: right side down).
  const Eigen::AngleAxisd pitch(pitch_up_deg * M_PI / 180.0, r);
  f = pitch * f, u = pitch * u;
  const Eigen::AngleAxisd roll(roll_right_down_deg * M_PI / 180.0, f);
  r = roll * r, u = roll * u;
  return {f, r, u};
}

/// A drive in a local ENU world: a 60 m circle then a figure of eight, 100 Hz, rolling and
/// pitching a little, from UNIX time t0_s. Heading covers all directions.
inline std::vector<StampedPose> synthetic_drive(double t0_s = 1700000000.0, double duration_s = 40.0, double rate_hz = 100.0) {
  std::vector<StampedPose> out;
  const int n = static_cast<int>(duration_s * rate_hz);
  for (int i = 0; i < n; ++i) {
    const double t = i / rate_hz, w = 2 * M_PI / 20.0;
    const Vec3 p(30.0 * std::sin(w * t) + 2.0 * std::sin(2 * w * t), 30.0 * std::cos(w * t) - 30.0, 1.5 + 0.3 * std::sin(0.3 * t));
    const Vec3 v(30.0 * w * std::cos(w * t) + 4.0 * w * std::cos(2 * w * t), -30.0 * w * std::sin(w * t), 0.0);
    const double yaw = std::atan2(v.y(), v.x());
    StampedPose s;
    s.t_s = t0_s + t;
    s.T_world_ins.linear() = rotation_from_rpy(Vec3(0.02 * std::sin(0.7 * t), -0.015 * std::cos(0.5 * t), yaw));
    s.T_world_ins.translation() = p;
    out.push_back(s);
  }
  return out;
}

/// Largest position (m) and rotation-angle (deg) differences, poses matched by index.
struct PoseDiff {
  double max_m = 0.0, max_deg = 0.0, max_dt_s = 0.0;
};
inline PoseDiff compare(const std::vector<StampedPose>& a, const std::vector<StampedPose>& b) {
  PoseDiff d;
  EXPECT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < std::min(a.size(), b.size()); ++i) {
    d.max_m = std::max(d.max_m, (a[i].T_world_ins.translation() - b[i].T_world_ins.translation()).norm());
    const Eigen::AngleAxisd dR(a[i].T_world_ins.linear() * b[i].T_world_ins.linear().transpose());
    d.max_deg = std::max(d.max_deg, std::abs(dR.angle()) * 180.0 / M_PI);
    d.max_dt_s = std::max(d.max_dt_s, std::abs(a[i].t_s - b[i].t_s));
  }
  return d;
}

inline double angle_deg(const Mat3& A, const Mat3& B) {
  return std::abs(Eigen::AngleAxisd(A * B.transpose()).angle()) * 180.0 / M_PI;
}

}  // namespace insalign::test
