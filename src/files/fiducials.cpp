#include "files/fiducials.hpp"

#include <charconv>
#include <cmath>
#include <fmt/format.h>
#include <set>
#include <sstream>
#include <stdexcept>

#include "core/errors.hpp"
#include "files/atomic_file.hpp"
#include "files/read_file.hpp"

namespace insalign::io {
namespace {

struct FiducialLine {
  std::string id;
  Vec3 values = Vec3::Zero();
  std::string where;
};

bool parse_number(std::string_view s, double& v) {
  if (!s.empty() && s.front() == '+') s.remove_prefix(1);
  auto [ptr, err] = std::from_chars(s.data(), s.data() + s.size(), v);
  return err == std::errc() && ptr == s.data() + s.size() && std::isfinite(v);
}

// Every "id a b c" line (comments stripped), ids unique; `names` say what a, b and c are.
std::vector<FiducialLine> parse_lines(const std::string& text, const std::string& file, const char* layout,
                                      const char* const names[3]) {
  std::istringstream in(text);
  std::vector<FiducialLine> out;
  std::set<std::string> ids;
  std::string line;
  for (std::size_t line_no = 1; std::getline(in, line); ++line_no) {
    if (const auto hash = line.find('#'); hash != std::string::npos) line.resize(hash);
    std::istringstream ss(line);
    std::vector<std::string> tok;
    for (std::string t; ss >> t;) tok.push_back(t);
    if (tok.empty()) continue;
    FiducialLine f{tok[0], Vec3::Zero(), "line " + std::to_string(line_no)};
    if (tok.size() != 4) throw InputError(file, f.where, fmt::format("expected '{}', found {} values", layout, tok.size()));
    for (int i = 0; i < 3; ++i) {
      if (!parse_number(tok[static_cast<std::size_t>(i) + 1], f.values[i])) {
        throw InputError(file, f.where, fmt::format("{} is not a finite number: '{}'", names[i], tok[i + 1]));
      }
    }
    if (!ids.insert(f.id).second) throw InputError(file, f.where, "duplicate fiducial id '" + f.id + "'");
    out.push_back(f);
  }
  return out;
}

std::string trimmed_lower(std::string_view s) {
  std::string out;
  for (char c : s) {
    if (c != ' ' && c != '\t' && c != '\r') out += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  }
  return out;
}

std::vector<Fiducial> geodetic_fiducials(const std::string& text, const std::string& file, const LocalEnu& enu) {
  static const char* const names[3] = {"latitude", "longitude", "height"};
  std::vector<Fiducial> out;
  for (const FiducialLine& f : parse_lines(text, file, "id lat_deg lon_deg ellipsoidal_height_m", names)) {
    const GeodeticPoint p{f.values.x(), f.values.y(), f.values.z()};
    try {
      check_geodetic(p);
    } catch (const std::invalid_argument& e) {
      throw InputError(file, f.where, e.what());
    }
    out.push_back({f.id, enu.position(p)});
  }
  return out;
}

}  // namespace

bool is_wgs84_fiducial_text(std::string_view text) {
  const std::string first = trimmed_lower(text.substr(0, text.find('\n')));
  return first == "#wgs84" || first == "#wgs-84";
}

std::vector<Fiducial> read_fiducials(const std::filesystem::path& path) {
  const std::string file = path.string();
  const std::string text = read_file(path);
  if (is_wgs84_fiducial_text(text)) {
    throw InputError(file, "line 1", "geodetic fiducials (# wgs84) need the local ENU frame of a geodetic INS source");
  }
  static const char* const names[3] = {"coordinate x", "coordinate y", "coordinate z"};
  std::vector<Fiducial> out;
  for (const FiducialLine& f : parse_lines(text, file, "id x y z", names)) out.push_back({f.id, f.values});
  return out;
}

std::vector<Fiducial> read_dataset_fiducials(const std::filesystem::path& path, const std::optional<LocalEnu>& enu,
                                             const Vec3& world_origin_m, const std::string& ins_source) {
  const std::string text = read_file(path);
  std::vector<Fiducial> out;
  if (is_wgs84_fiducial_text(text)) {
    if (!enu) {
      throw InputError(path.string(), "line 1",
                       fmt::format("geodetic fiducials (# wgs84) need a geodetic INS source (NovAtel, SBET, a text export, "
                                   "KITTI oxts, INSPVA(X), NavSatFix + Imu); {} is cartesian: give the fiducials as "
                                   "'id x y z' in its world frame",
                                   ins_source));
    }
    out = geodetic_fiducials(text, path.string(), *enu);
  } else {
    out = read_fiducials(path);
  }
  for (Fiducial& f : out) f.p_world -= world_origin_m;
  return out;
}

void write_fiducials(const std::filesystem::path& path, const std::vector<Fiducial>& fiducials) {
  std::string out = "# id x y z (metres, world frame of the pose file)\n";
  for (const Fiducial& f : fiducials) {
    out += fmt::format("{} {} {} {}\n", f.id, f.p_world.x(), f.p_world.y(), f.p_world.z());
  }
  write_file_atomic(path, out);
}

void write_geodetic_fiducials(const std::filesystem::path& path, const std::vector<Fiducial>& fiducials,
                              const LocalEnu& enu, const Vec3& world_origin_m) {
  std::string out = "# wgs84\n# id lat_deg lon_deg ellipsoidal_height_m\n";
  for (const Fiducial& f : fiducials) {
    const GeodeticPoint p = enu.geodetic(f.p_world + world_origin_m);
    out += fmt::format("{} {} {} {}\n", f.id, p.lat_deg, p.lon_deg, p.height_m);  // shortest exact form
  }
  write_file_atomic(path, out);
}

}  // namespace insalign::io
