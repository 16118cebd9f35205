// PCD v0.7 point clouds (the LiDAR frames of the OpenCalib layout): read any DATA encoding, field
// order, size and type; write binary / binary_compressed / ascii.
#pragma once

#include <cstddef>
#include <filesystem>
#include <string>
#include <vector>

#include "core/sweep.hpp"

namespace insalign::io {

enum class PcdEncoding { kAscii, kBinary, kBinaryCompressed };

/// Which per-point time field write_pcd stores.
enum class PcdTimeField {
  kAbsolute,  ///< "timestamp", double, absolute seconds (needs a finite sweep.t_end_s)
  kRelative,  ///< "time", float seconds relative to the sweep end (<= 0)
  kNone,      ///< no time field
};

/// What read_pcd found, for reports.
struct PcdInfo {
  std::size_t points = 0;         ///< points in the file (POINTS), including dropped ones
  std::size_t dropped_nonfinite = 0;  ///< points dropped because x, y, z or the time was NaN/Inf
  std::string time_field;         ///< "timestamp", "time", "t" or "" (none)
  std::string data_encoding;      ///< "ascii", "binary" or "binary_compressed"
};

/// Header of a PCD file, parsed without touching the data.
struct PcdHeader {
  struct Field {
    std::string name;
    int size = 4;        ///< bytes per element: 1, 2, 4 or 8
    char type = 'F';     ///< 'F' float, 'U' unsigned, 'I' signed
    int count = 1;       ///< elements
    std::size_t offset = 0;  ///< byte offset of the first element within a point (binary layout)
  };
  std::vector<Field> fields;
  std::size_t width = 0, height = 0, points = 0;
  std::string data;           ///< "ascii", "binary" or "binary_compressed"
  std::size_t point_bytes = 0;   ///< sum of size * count
  std::size_t header_bytes = 0;  ///< byte offset where the data starts
  std::size_t header_lines = 0;  ///< lines in the header (ascii data starts on line header_lines + 1)
  const Field* find(const std::string& name) const;
};

/// Parses only the header. Throws InputError(file, "line N", what).
PcdHeader read_pcd_header(const std::filesystem::path& path);

/// Reads a sweep. Points with non-finite coordinates or time are dropped (counted in info).
/// Time: "timestamp" (absolute s): t_end_s = max timestamp, dt_s = timestamp - t_end_s;
/// "time" (s) and "t" (uint ns from the sweep start) are relative: dt_s = time - max(time) and
/// t_end_s = NaN (the caller fills it from the frame name or pose file); no time field: dt_s empty
/// and t_end_s = NaN. name = the file's stem. Throws InputError(file, "line N"/"byte N", what).
Sweep read_pcd(const std::filesystem::path& path, PcdInfo* info = nullptr);

/// Writes x y z, intensity and ring if present, and the time field; atomically.
void write_pcd(const std::filesystem::path& path, const Sweep& sweep,
               PcdEncoding encoding = PcdEncoding::kBinaryCompressed,
               PcdTimeField time_field = PcdTimeField::kAbsolute);

}  // namespace insalign::io
