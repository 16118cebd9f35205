// Surveyed fiducial points: "id x y z" per line in the pose file's world frame, '#' comments.
#pragma once

#include <filesystem>
#include <vector>

#include "core/dataset.hpp"

namespace insalign::io {

/// Throws InputError(file, "line N", what) on a malformed line or a duplicate id.
std::vector<Fiducial> read_fiducials(const std::filesystem::path& path);

void write_fiducials(const std::filesystem::path& path, const std::vector<Fiducial>& fiducials);

}  // namespace insalign::io
