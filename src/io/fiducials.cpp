#include "io/fiducials.hpp"

#include <charconv>
#include <cmath>
#include <fmt/format.h>
#include <fstream>
#include <set>
#include <sstream>

#include "core/errors.hpp"
#include "io/atomic_file.hpp"
#include "io/read_file.hpp"

namespace insalign::io {

std::vector<Fiducial> read_fiducials(const std::filesystem::path& path) {
  const std::string file = path.string();
  std::istringstream in(read_file(path));
  std::vector<Fiducial> out;
  std::set<std::string> ids;
  std::string line;
  std::size_t line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    if (const auto hash = line.find('#'); hash != std::string::npos) line.resize(hash);
    std::istringstream ss(line);
    std::vector<std::string> tok;
    for (std::string t; ss >> t;) tok.push_back(t);
    if (tok.empty()) continue;
    const std::string where = "line " + std::to_string(line_no);
    if (tok.size() != 4) {
      throw InputError(file, where, fmt::format("expected 'id x y z', found {} values", tok.size()));
    }
    Fiducial f;
    f.id = tok[0];
    for (int i = 0; i < 3; ++i) {
      std::string_view s = tok[static_cast<std::size_t>(i) + 1];
      if (!s.empty() && s.front() == '+') s.remove_prefix(1);
      double v = 0.0;
      auto [ptr, err] = std::from_chars(s.data(), s.data() + s.size(), v);
      if (err != std::errc() || ptr != s.data() + s.size() || !std::isfinite(v)) {
        throw InputError(file, where, fmt::format("coordinate {} is not a finite number: '{}'", "xyz"[i], tok[i + 1]));
      }
      f.p_world[i] = v;
    }
    if (!ids.insert(f.id).second) throw InputError(file, where, "duplicate fiducial id '" + f.id + "'");
    out.push_back(f);
  }
  return out;
}

void write_fiducials(const std::filesystem::path& path, const std::vector<Fiducial>& fiducials) {
  std::string out = "# id x y z (metres, world frame of the pose file)\n";
  for (const Fiducial& f : fiducials) {
    out += fmt::format("{} {} {} {}\n", f.id, f.p_world.x(), f.p_world.y(), f.p_world.z());
  }
  write_file_atomic(path, out);
}

}  // namespace insalign::io
