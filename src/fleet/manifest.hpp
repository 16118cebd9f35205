// The fleet manifest (CONVENTIONS.md "Fleets"): a CSV file (RFC 4180 quoting) with a header and
// one row per task: which car, which day, check or calibrate, which recording, which extrinsic.
#pragma once

#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

namespace insalign::fleet {

/// One manifest row; `line` is the 1-based line where the row starts (for messages).
struct ManifestRow {
  std::string car;
  std::string date;       ///< ISO 8601 (2026-03-01 or 2026-03-01T08:30:00Z)
  std::string kind;       ///< "check" or "calibrate"
  std::string input;      ///< INPUT options exactly as on the command line
  std::string extrinsic;  ///< check: the installed extrinsic FILE; calibrate: empty
  std::string options;    ///< more options for the command (may be empty)
  int line = 0;

  /// `<car>/<date>-<kind>`: the row's id, its folder under the results.
  std::string id() const { return car + "/" + date + "-" + kind; }
};

struct Manifest {
  std::filesystem::path file;    ///< absolute path of the manifest
  std::filesystem::path folder;  ///< relative paths in the rows are taken from here
  std::vector<ManifestRow> rows;
};

/// Parses manifest text. Throws InputError(file_name, "line L, column C", what) for bad CSV, a
/// missing or unknown column, an unknown kind, a bad date, an empty car, a path-like car or date
/// that would escape the results folder, a check row without extrinsic, or duplicate ids.
Manifest parse_manifest(std::string_view text, const std::string& file_name);

/// Reads and parses a manifest file; `folder` and `file` are made absolute.
Manifest read_manifest(const std::filesystem::path& path);

/// Splits an option string into words like a POSIX shell does for plain words: whitespace
/// separates, single and double quotes group, backslash escapes. Throws InputError(file_name,
/// location, ...) on an unterminated quote.
std::vector<std::string> split_words(std::string_view text, const std::string& file_name, const std::string& location);

}  // namespace insalign::fleet
