// rosbag2 storage: sqlite3 `.db3` files (every schema version) and rosbag2 folders (their
// metadata.yaml, or their storage files in name order), read and written. open_bag (bag_reader.hpp)
// is the entry point users call; these are its parts, exposed for tests and the fuzz harness.
#pragma once

#include <filesystem>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "recording/bag_reader.hpp"
#include "recording/bag_writer.hpp"

namespace insalign::io::bag {

/// True when `first_bytes` start with the sqlite3 header "SQLite format 3\0" (16 bytes).
bool is_sqlite3(std::string_view first_bytes);

/// Reads one rosbag2 sqlite3 file, any schema version (old `topics` + `messages` only, or with
/// `schema`, `metadata`, `message_definitions`), opened read-only: the file is never modified.
/// Messages are indexed by row id (no blob read); read() is thread-safe and runs in parallel (a
/// pool of read-only connections). Throws InputError(path, "", what) for a file that is not a
/// sqlite3 database, lacks the rosbag2 tables, or is truncated.
std::unique_ptr<BagReader> open_rosbag2_db3(const std::filesystem::path& path);

/// What open_bag needs from a rosbag2 metadata.yaml (`rosbag2_bagfile_information`, versions
/// 1-9; unknown keys are ignored).
struct Rosbag2Metadata {
  int version = 0;
  std::string storage_identifier;                ///< "sqlite3", "mcap", ...
  std::vector<std::string> relative_file_paths;  ///< as written, in order
  std::string compression_format;                ///< "" when not compressed
  std::string compression_mode;                  ///< "", "FILE" or "MESSAGE"
  std::uint64_t message_count = 0;
  std::vector<std::string> warnings;  ///< what was tolerated
};

/// Parses metadata.yaml text; `file` names it in errors. Throws InputError(file, "line N", what).
Rosbag2Metadata parse_rosbag2_metadata(std::string_view yaml_text, const std::string& file);

/// The storage files of a rosbag2 folder, in order: those metadata.yaml names (resolved as rosbag2
/// does: version < 4 relative to the parent folder), or without one the folder's `.db3` / `.mcap`
/// files in natural name order (x_2 before x_10). `warnings` receives what was tolerated. Throws
/// InputError naming the folder when it holds no bag file, or naming the yaml and the file when
/// metadata.yaml lists a missing one or describes a compressed bag.
std::vector<std::filesystem::path> rosbag2_folder_files(const std::filesystem::path& folder,
                                                        std::vector<std::string>& warnings);

/// One BagReader over the readers of one bag's files (a split bag, whatever each file's storage):
/// topics merged by name (and type), message counts summed, MessageRef.locator2 = the file's index
/// in `parts`, messages in log-time order (ties in file order). `path` is the folder.
std::unique_ptr<BagReader> concatenate_bags(std::vector<std::unique_ptr<BagReader>> parts,
                                            const std::filesystem::path& path, std::vector<std::string> warnings);

/// Writes a rosbag2 folder: `<folder name>_0.db3` (schema version 4 with `schema`, `metadata` and
/// `message_definitions`, ros_distro "humble") and a metadata.yaml (version 5) that `ros2 bag info`
/// reads. Built in a hidden temporary folder beside `folder` and renamed into place on close();
/// an existing rosbag2 folder (or empty folder) at `folder` is replaced, anything else is refused.
/// Topic types are stored in the ROS 2 form ("sensor_msgs/msg/Imu"); topics must be kCdr.
std::unique_ptr<BagWriter> make_rosbag2_writer(const std::filesystem::path& folder, const WriterOptions& options);

}  // namespace insalign::io::bag
