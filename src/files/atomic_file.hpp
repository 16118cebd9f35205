// Outputs are written to a temporary file beside the target and renamed into place, so a failed
// or interrupted run never leaves a half-written result.
#pragma once

#include <filesystem>
#include <string_view>

namespace insalign::io {

/// Writes `content` to `path` atomically. Throws InputError naming the path if it cannot.
void write_file_atomic(const std::filesystem::path& path, std::string_view content);

/// Creates `dir` (and parents) and checks it is writable. Throws InputError naming it if not.
void ensure_writable_dir(const std::filesystem::path& dir);

}  // namespace insalign::io
