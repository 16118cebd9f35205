// One entry point for the INS logs and datasets that are not pose files: detect the format from the
// content, read it into an InsTrack (to_world() then places it in the local ENU frame).
//
//   detect_ins_log(path)             which format, or nullopt: leave the file to files/poses.hpp
//                                    (OpenCalib, TUM)
//   read_ins_log(path, format, opt)  the track, with format, time base, body frame and height
//                                    datum filled for `insalign info`, skipped records counted and
//                                    explained in warnings
//
// Detection, in this order:
//   a folder with data/*.txt and timestamps.txt (or holding such an oxts/ folder)  -> kKittiOxts
//   '#'/'%' NovAtel ASCII records ('#INSPVAXA,', '%INSPVASA,', '#BESTPOSA,' ...) in the first 64 KB
//                                                                                 -> kNovatelAscii
//   binary content whose first records are plausible SBET records, or binary content named
//   *.out / *.sbet (read_ins_log then names a size that is not a multiple of 136)  -> kSbet
//   binary content starting with NovAtel's sync bytes AA 44 12 / 13 (binary logs are not read:
//   read_ins_log says to convert them to ASCII)                                   -> kNovatelAscii
//   text with a header row of column names over numeric rows                      -> kTextExport
//     (reading it needs a column mapping; without one read_ins_log throws an InputError listing the
//     header's columns, with the mapping for Inertial Explorer and POSPac exports it recognises)
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <string_view>

#include "inslog/ins_track.hpp"
#include "inslog/novatel_ascii.hpp"
#include "inslog/text_export.hpp"

namespace insalign::io {

enum class InsLogFormat { kNovatelAscii, kSbet, kTextExport, kKittiOxts };

/// "novatel", "sbet", "csv", "kitti": the names of --poses-format.
const char* ins_log_format_name(InsLogFormat format);
std::optional<InsLogFormat> parse_ins_log_format(std::string_view name);

struct InsLogOptions {
  /// The LiDAR's first stamp (UNIX s): dates GPS seconds of week without a week (SBET, text
  /// exports mapped gps-sow without a week column). Required for those; unused otherwise.
  std::optional<double> lidar_time_hint_unix_s;
  /// Text exports: the column mapping (parse_text_export_columns). Empty: InputError listing the columns.
  TextExportColumns columns;
  /// NovAtel: how many bad-CRC records make the file corrupt.
  NovatelReadOptions novatel;
};

/// The format of `path` from its content (see above); nullopt for anything else (pose files).
/// Throws InputError only when `path` does not exist or cannot be read.
std::optional<InsLogFormat> detect_ins_log(const std::filesystem::path& path);

/// Reads `path` as `format`. Throws InputError(file, "line N" / "byte N", what).
InsTrack read_ins_log(const std::filesystem::path& path, InsLogFormat format, const InsLogOptions& options = {});

}  // namespace insalign::io
