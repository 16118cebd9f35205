#include "files/read_file.hpp"

#include <fstream>
#include <sstream>

#include "core/errors.hpp"

namespace insalign::io {

std::string read_file(const std::filesystem::path& path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) {
    throw InputError(path.string(), "", std::filesystem::exists(path, ec) ? "not a regular file" : "file not found");
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path.string(), "", "cannot open");
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

}  // namespace insalign::io
