#include "pointcloud/ply.hpp"

#include <cstring>
#include <fstream>
#include <sstream>
#include <string>

#include "core/errors.hpp"
#include "files/atomic_file.hpp"

namespace insalign::io {

void write_ply(const std::filesystem::path& path, const std::vector<Vec3f>& points) {
  std::string data = "ply\nformat binary_little_endian 1.0\ncomment written by insalign\nelement vertex " +
                     std::to_string(points.size()) + "\nproperty float x\nproperty float y\nproperty float z\nend_header\n";
  const std::size_t header = data.size();
  data.resize(header + points.size() * 3 * sizeof(float));
  for (std::size_t i = 0; i < points.size(); ++i) {
    std::memcpy(data.data() + header + i * 3 * sizeof(float), points[i].data(), 3 * sizeof(float));
  }
  write_file_atomic(path, data);
}

std::vector<Vec3f> read_ply(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path.string(), "", "cannot open");
  std::string line;
  std::size_t count = 0;
  int line_no = 0;
  bool xyz_float = false;
  while (std::getline(in, line)) {
    ++line_no;
    if (line.rfind("element vertex ", 0) == 0) count = std::stoull(line.substr(15));
    if (line == "property float x") xyz_float = true;
    if (line.rfind("format ", 0) == 0 && line != "format binary_little_endian 1.0") {
      throw InputError(path.string(), "line " + std::to_string(line_no), "only binary_little_endian PLY is read");
    }
    if (line == "end_header") break;
  }
  if (!xyz_float) throw InputError(path.string(), "", "no float x y z vertex properties");
  std::vector<Vec3f> points(count);
  in.read(reinterpret_cast<char*>(points.data()), static_cast<std::streamsize>(count * 3 * sizeof(float)));
  if (static_cast<std::size_t>(in.gcount()) != count * 3 * sizeof(float)) {
    throw InputError(path.string(), "byte " + std::to_string(in.gcount()), "vertex data truncated");
  }
  return points;
}

}  // namespace insalign::io
