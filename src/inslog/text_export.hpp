// Text exports of post-processed trajectories (NovAtel Inertial Explorer, Applanix POSPac, in-house
// CSVs): a header row naming the columns, then one row per epoch. There is no fixed layout, so the
// columns are mapped BY NAME through TextExportColumns (from --poses-columns or the YAML config).
//
// Layout: any preamble lines, the header row (the first line holding every mapped column name), an
// optional units row (any row that is not numbers, before the first data row), data rows. '#' lines
// and blank lines are skipped. Delimiters are detected per row kind (POSPac writes a comma-separated
// header over whitespace-separated numbers): tab, ';', ',' or whitespace; with ';' a decimal comma
// ("12,5") is read as a decimal point. Column names match case-insensitively, trimmed and unquoted;
// a name that repeats (POSPac's "ELLIPSOID HEIGHT") maps to its first column. Every data row has as
// many fields as the header has columns (a value holding spaces, e.g. degrees minutes seconds,
// would shift the columns after it: an InputError naming the line).
//
// Attitude: roll, pitch and heading are the Euler angles of the named body frame in its own
// convention (inslog/attitude.hpp): x-forward-y-right-z-down: R_enu_ins_ned (aerospace ZYX, heading
// clockwise from north; POSPac); x-forward-y-left-z-up: R_enu_ins_enu (ZYX, yaw counter-clockwise
// from east; ROS REP-103); x-right-y-forward-z-up: R_enu_ins_novatel (NovAtel SPAN: azimuth, pitch
// about x, roll about y; Inertial Explorer). A heading given in the other convention is converted
// (cw-from-north = 90 - ccw-from-east).
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "inslog/ins_track.hpp"

namespace insalign::io {

enum class TextTimeBase {
  kUnix,              ///< "unix": UNIX seconds (UTC)
  kGpsSecondsOfWeek,  ///< "gps-sow": GPS seconds of week; week from `week` or the LiDAR clock
  kGpsWeekSeconds,    ///< "gps-week-seconds": GPS seconds of week with the week from `week` (required)
  kGpsSeconds,        ///< "gps": GPS seconds since 1980-01-06 (week * 604800 + seconds of week)
};
enum class TextHeightDatum { kEllipsoidal /* "ellipsoidal" */, kMeanSeaLevel /* "msl": + undulation */ };
enum class HeadingConvention { kClockwiseFromNorth /* "cw-from-north" */, kCounterClockwiseFromEast /* "ccw-from-east" */ };
enum class AngleUnit { kDegrees /* "deg" */, kRadians /* "rad" */ };
enum class TextBodyFrame {
  kForwardRightDown,  ///< "x-forward-y-right-z-down"
  kForwardLeftUp,     ///< "x-forward-y-left-z-up"
  kRightForwardUp,    ///< "x-right-y-forward-z-up"
};
/// How a status column's values map to GnssSolution.
enum class StatusCode {
  kIeQuality,  ///< "ie-quality": Inertial Explorer Q: 1 fixed, 2-3 float, 4 DGPS, 5 single, 6 invalid
  kGga,        ///< "gga": NMEA GGA quality: 0 invalid, 1 single, 2/3/9 differential, 4 fixed, 5 float, 6 INS only
  kNovatel,    ///< "novatel": NovAtel position types (INS_RTKFIXED, NARROW_INT, PSRDIFF, SINGLE, ...)
};
enum class TextDelimiter { kAuto, kComma, kSemicolon, kTab, kWhitespace };

/// Column mapping: column names as the header writes them. Empty names are unmapped. Required:
/// time, lat, lon, height, roll, pitch, heading (plus week for gps-week-seconds, undulation for msl).
struct TextExportColumns {
  std::string time;
  TextTimeBase time_base = TextTimeBase::kUnix;
  std::string week;                                   ///< GPS week column
  std::string latitude, longitude;
  AngleUnit latlon_units = AngleUnit::kDegrees;
  std::string height;
  TextHeightDatum height_datum = TextHeightDatum::kEllipsoidal;
  std::string undulation;                             ///< geoid undulation (m), ellipsoidal = msl + undulation
  std::string roll, pitch, heading;
  HeadingConvention heading_convention = HeadingConvention::kClockwiseFromNorth;
  AngleUnit units = AngleUnit::kDegrees;              ///< roll, pitch, heading
  TextBodyFrame frame = TextBodyFrame::kForwardRightDown;
  std::string sd_east, sd_north, sd_up;               ///< one-sigma position errors (m), optional
  std::string sd_horizontal;                          ///< one horizontal sigma (m): east = north = it / sqrt 2
  std::string status;                                 ///< GNSS solution column, optional
  StatusCode status_code = StatusCode::kIeQuality;
  TextDelimiter delimiter = TextDelimiter::kAuto;     ///< of the data rows; the header's is detected

  bool empty() const { return time.empty() && latitude.empty() && longitude.empty() && height.empty(); }
};

/// Parses a compact spec: comma-separated key=value, a value optionally followed by ':qualifier',
/// values may be double-quoted to hold ',' ':' or '='. Keys (qualifiers in brackets, defaults first):
///   time=COL[:unix|gps-sow|gps-week-seconds|gps]  week=COL
///   lat=COL  lon=COL  latlon-units=deg|rad
///   height=COL[:ellipsoidal|msl]  undulation=COL
///   roll=COL  pitch=COL  heading=COL[:cw-from-north|ccw-from-east]  (yaw=COL: heading, default ccw-from-east)
///   units=deg|rad  frame=x-forward-y-right-z-down|x-forward-y-left-z-up|x-right-y-forward-z-up
///   sd-east=COL  sd-north=COL  sd-up=COL  sd-horizontal=COL  status=COL[:ie-quality|gga|novatel]
///   delimiter=auto|comma|semicolon|tab|whitespace
/// e.g. "time=GPSTime:gps-sow,lat=Latitude,lon=Longitude,height=H-Ell,roll=Roll,pitch=Pitch,
/// heading=Heading:cw-from-north,units=deg,frame=x-right-y-forward-z-up". Throws
/// InputError(source, "", what) naming the bad key or value and the allowed ones; checks that the
/// required keys are there.
TextExportColumns parse_text_export_columns(const std::string& spec, const std::string& source = "--poses-columns");
/// The spec that parse_text_export_columns turns back into `columns` (for messages and configs).
std::string format_text_export_columns(const TextExportColumns& columns);

/// Reads the export into a geodetic InsTrack. `lidar_time_hint_unix_s` dates gps-sow times that
/// have no week column. Without a mapping (columns.empty()) throws InputError listing the header's
/// columns and a mapping to start from. Throws InputError(file, "line N", what) for bad rows, times
/// that do not increase, latitude beyond +-90, non-finite values; a cut-short LAST row is skipped.
InsTrack read_text_export(const std::filesystem::path& path, const TextExportColumns& columns,
                          std::optional<double> lidar_time_hint_unix_s = std::nullopt);
InsTrack parse_text_export(std::string_view text, const std::string& file_for_errors, const TextExportColumns& columns,
                           std::optional<double> lidar_time_hint_unix_s = std::nullopt);

/// The header row's column names, if `text` (a file's first bytes) has a header row over numeric rows.
std::optional<std::vector<std::string>> text_export_header(std::string_view text);

}  // namespace insalign::io
