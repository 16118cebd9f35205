// Binary little-endian PLY point clouds (CloudCompare, MeshLab, RViz plugins read them).
#pragma once

#include <filesystem>
#include <vector>

#include "core/geometry.hpp"

namespace insalign::io {

/// Writes x y z (float) vertices atomically.
void write_ply(const std::filesystem::path& path, const std::vector<Vec3f>& points);

/// Reads the x y z float vertices of a binary little-endian PLY written by write_ply.
std::vector<Vec3f> read_ply(const std::filesystem::path& path);

}  // namespace insalign::io
