// Reading a whole input file, with the error every reader gives for a missing or unreadable one.
#pragma once

#include <filesystem>
#include <string>

namespace insalign::io {

/// The bytes of `path`. Throws InputError naming it: "file not found", "not a regular file" (a
/// folder given for a file) or "cannot open" (permissions).
std::string read_file(const std::filesystem::path& path);

}  // namespace insalign::io
