#include "files/poses.hpp"

#include <charconv>
#include <cmath>
#include <fmt/format.h>
#include <fstream>
#include <limits>
#include <sstream>

#include "core/errors.hpp"
#include "files/atomic_file.hpp"
#include "files/read_file.hpp"

namespace insalign::io {

namespace {

constexpr double kOrthonormalTolerance = 1e-3;  // larger errors mean a wrong matrix, not rounding
constexpr double kRoundingTolerance = 1e-6;     // below this, a fix is just print rounding (not counted)

std::vector<std::string_view> split_ws(std::string_view s) {
  std::vector<std::string_view> out;
  std::size_t i = 0;
  while (i < s.size()) {
    while (i < s.size() && std::isspace(static_cast<unsigned char>(s[i]))) ++i;
    std::size_t j = i;
    while (j < s.size() && !std::isspace(static_cast<unsigned char>(s[j]))) ++j;
    if (j > i) out.push_back(s.substr(i, j - i));
    i = j;
  }
  return out;
}

bool parse_double(std::string_view s, double& out) {
  if (!s.empty() && s.front() == '+') s.remove_prefix(1);
  const char* end = s.data() + s.size();
  auto [ptr, ec] = std::from_chars(s.data(), end, out);
  return ec == std::errc() && ptr == end && std::isfinite(out);
}


// Checks R is a rotation within tolerance and returns the nearest exact rotation.
Mat3 checked_rotation(const Mat3& R, const std::string& file, const std::string& where, std::size_t* fixed) {
  const double deviation = (R.transpose() * R - Mat3::Identity()).cwiseAbs().maxCoeff();
  if (!(deviation <= kOrthonormalTolerance)) {
    throw InputError(file, where, fmt::format("rotation is not orthonormal (|R^T R - I| = {:.3g}, allowed {})",
                                              deviation, kOrthonormalTolerance));
  }
  if (R.determinant() < 0) throw InputError(file, where, "rotation has determinant -1 (a reflection)");
  if (fixed && deviation > kRoundingTolerance) ++*fixed;
  return nearest_rotation(R);
}

// Days since 1970-01-01 of a proleptic Gregorian date (civil calendar arithmetic).
long long days_from_civil(long long y, unsigned m, unsigned d) {
  y -= m <= 2;
  const long long era = (y >= 0 ? y : y - 399) / 400;
  const unsigned yoe = static_cast<unsigned>(y - era * 400);
  const unsigned doy = (153 * (m > 2 ? m - 3 : m + 9) + 2) / 5 + d - 1;
  const unsigned doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
  return era * 146097 + static_cast<long long>(doe) - 719468;
}

bool all_digits(std::string_view s) {
  if (s.empty()) return false;
  for (char c : s) {
    if (c < '0' || c > '9') return false;
  }
  return true;
}

std::string number(double v) { return fmt::format("{}", v); }

}  // namespace

std::optional<double> time_from_frame_name(std::string_view name) {
  if (name.empty()) return std::nullopt;
  // Integer: unit from the digit count.
  if (all_digits(name)) {
    std::size_t frac_digits = 0;  // 19 digits: ns, 16: us, 13: ms, 10: s
    switch (name.size()) {
      case 19: frac_digits = 9; break;
      case 16: frac_digits = 6; break;
      case 13: frac_digits = 3; break;
      case 10: frac_digits = 0; break;
      default: return std::nullopt;
    }
    // Seconds and fraction parsed apart so that 19 digits keep their precision in a double.
    const std::size_t sec_digits = name.size() - frac_digits;
    double sec = 0.0, frac = 0.0;
    std::from_chars(name.data(), name.data() + sec_digits, sec);
    if (frac_digits > 0) {
      std::from_chars(name.data() + sec_digits, name.data() + name.size(), frac);
      frac *= std::pow(10.0, -static_cast<double>(frac_digits));
    }
    return sec + frac;
  }
  // Decimal seconds.
  const std::size_t dot = name.find('.');
  if (dot != std::string_view::npos && name.find('.', dot + 1) == std::string_view::npos &&
      all_digits(name.substr(0, dot)) && (dot + 1 == name.size() || all_digits(name.substr(dot + 1)))) {
    double v = 0.0;
    if (parse_double(name, v)) return v;
    return std::nullopt;
  }
  // YYYY-MM-DD-HH-MM-SS[-fraction] ('-' or '_' separators), read as UTC.
  std::vector<std::string_view> parts;
  std::size_t start = 0;
  for (std::size_t i = 0; i <= name.size(); ++i) {
    if (i == name.size() || name[i] == '-' || name[i] == '_') {
      parts.push_back(name.substr(start, i - start));
      start = i + 1;
    }
  }
  if (parts.size() != 6 && parts.size() != 7) return std::nullopt;
  const std::size_t widths[] = {4, 2, 2, 2, 2, 2};
  long long v[6];
  for (int i = 0; i < 6; ++i) {
    if (parts[i].size() != widths[i] || !all_digits(parts[i])) return std::nullopt;
    std::from_chars(parts[i].data(), parts[i].data() + parts[i].size(), v[i]);
  }
  if (v[1] < 1 || v[1] > 12 || v[2] < 1 || v[2] > 31 || v[3] > 23 || v[4] > 59 || v[5] > 60) return std::nullopt;
  double frac = 0.0;
  if (parts.size() == 7) {
    if (!all_digits(parts[6]) || parts[6].size() > 9) return std::nullopt;
    double f = 0.0;
    std::from_chars(parts[6].data(), parts[6].data() + parts[6].size(), f);
    frac = f * std::pow(10.0, -static_cast<double>(parts[6].size()));
  }
  const long long days = days_from_civil(v[0], static_cast<unsigned>(v[1]), static_cast<unsigned>(v[2]));
  return static_cast<double>(days * 86400 + v[3] * 3600 + v[4] * 60 + v[5]) + frac;
}

namespace {

// The format is fixed by the first pose line: 8 values TUM, 13 OpenCalib.
PoseFormat detect_pose_format(std::size_t values, const std::string& file, const std::string& where) {
  if (values == 8) return PoseFormat::kTum;
  if (values == 13) return PoseFormat::kOpenCalib;
  throw InputError(file, where,
                   fmt::format("{} values: expected 13 (OpenCalib: frame name and 3x4 T_world_ins) or 8 "
                               "(TUM: t x y z qx qy qz qw)",
                               values));
}

// One pose line (already split, format known) appended to `out`.
void add_pose_line(const std::vector<std::string_view>& tok, std::size_t line_no, const std::string& file, PoseFile& out) {
  const std::string where = "line " + std::to_string(line_no);
  const bool tum = out.format == PoseFormat::kTum;
  const std::size_t expected = tum ? 8 : 13;
  if (tok.size() != expected) {
    throw InputError(file, where,
                     fmt::format("{} values, expected {} like the lines before ({} format)", tok.size(), expected,
                                 tum ? "TUM" : "OpenCalib"));
  }
  double v[13];
  for (std::size_t i = (tum ? 0 : 1); i < expected; ++i) {
    if (!parse_double(tok[i], v[i])) {
      throw InputError(file, where, fmt::format("value {} is not a finite number: '{}'", i + 1, tok[i]));
    }
  }
  Iso3 T_world_ins = Iso3::Identity();
  if (tum) {
    Eigen::Quaterniond q(v[7], v[4], v[5], v[6]);
    const double norm = q.norm();
    if (std::abs(norm - 1.0) > kOrthonormalTolerance) {
      throw InputError(file, where, fmt::format("quaternion norm {:.6g} is not 1", norm));
    }
    if (std::abs(norm - 1.0) > kRoundingTolerance) ++out.reorthonormalised;
    T_world_ins.linear() = q.normalized().toRotationMatrix();
    T_world_ins.translation() = Vec3(v[1], v[2], v[3]);
    out.t_s.push_back(v[0]);
  } else {
    Mat3 R;
    R << v[1], v[2], v[3], v[5], v[6], v[7], v[9], v[10], v[11];
    T_world_ins.linear() = checked_rotation(R, file, where, &out.reorthonormalised);
    T_world_ins.translation() = Vec3(v[4], v[8], v[12]);
    out.frame_names.emplace_back(tok[0]);
    out.t_s.push_back(time_from_frame_name(tok[0]).value_or(std::numeric_limits<double>::quiet_NaN()));
  }
  out.T_world_ins.push_back(T_world_ins);
  out.line.push_back(line_no);
}

}  // namespace

PoseFile read_pose_file(const std::filesystem::path& path) {
  const std::string file = path.string();
  const std::string text = read_file(path);
  PoseFile out;
  bool format_known = false;
  std::size_t line_no = 0, pos = 0;
  while (pos < text.size()) {
    std::size_t nl = text.find('\n', pos);
    if (nl == std::string::npos) nl = text.size();
    std::string_view line(text.data() + pos, nl - pos);
    pos = nl + 1;
    ++line_no;
    if (const std::size_t hash = line.find('#'); hash != std::string_view::npos) line = line.substr(0, hash);
    const auto tok = split_ws(line);
    if (tok.empty()) continue;
    if (!format_known) out.format = detect_pose_format(tok.size(), file, "line " + std::to_string(line_no));
    format_known = true;
    add_pose_line(tok, line_no, file, out);
  }
  if (out.T_world_ins.empty()) throw InputError(file, "", "no poses in the file");
  return out;
}

void write_opencalib_poses(const std::filesystem::path& path, const std::vector<std::string>& frame_names,
                           const std::vector<Iso3>& T_world_ins) {
  if (frame_names.size() != T_world_ins.size()) {
    throw std::invalid_argument("write_opencalib_poses: names and poses differ in number");
  }
  std::string out;
  for (std::size_t i = 0; i < frame_names.size(); ++i) {
    out += frame_names[i];
    const Eigen::Matrix4d M = T_world_ins[i].matrix();
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 4; ++c) out += " " + number(M(r, c));
    }
    out += '\n';
  }
  write_file_atomic(path, out);
}

void write_tum_poses(const std::filesystem::path& path, const std::vector<StampedPose>& poses) {
  std::string out = "# t x y z qx qy qz qw (T_world_ins)\n";
  for (const StampedPose& p : poses) {
    const Eigen::Quaterniond q(p.T_world_ins.linear());
    const Vec3 t = p.T_world_ins.translation();
    out += fmt::format("{} {} {} {} {} {} {} {}\n", p.t_s, t.x(), t.y(), t.z(), q.x(), q.y(), q.z(), q.w());
  }
  write_file_atomic(path, out);
}

}  // namespace insalign::io
