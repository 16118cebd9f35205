// The input options calibrate, info and stitch share (CONVENTIONS.md "Command line",
// "Recordings", "INS logs and KITTI raw", "Rigs"), and the configuration options beside them:
// one place that adds them to a subcommand and one that turns them into io::load_input's
// arguments, so that every command reads the same inputs the same way.
#pragma once

#include <CLI/CLI.hpp>
#include <string>
#include <vector>

#include "tool/tool_config.hpp"
#include "input/input_source.hpp"

namespace insalign::cli {

struct InputOptions {
  std::vector<std::string> lidar_dirs;   ///< --lidar-dir, repeatable (a rig)
  std::string poses;                     ///< --poses: any pose source io::read_pose_source detects
  std::string bag;                       ///< --bag
  std::vector<std::string> lidar_topics; ///< --lidar-topic, repeatable
  std::string ins_topic;                 ///< --ins-topic ("" automatic; "FIX,IMU" a NavSatFix + Imu pair)
  std::string world_frame, ins_frame;    ///< --world-frame, --ins-frame (TF)
  std::string poses_columns;             ///< --poses-columns (text exports; overrides input.poses_columns)
  std::string kitti_raw;                 ///< --kitti-raw
  std::vector<std::string> inits;        ///< --init, repeatable, in the LiDARs' order
  std::string fiducials;                 ///< --fiducials
};

struct ConfigOptions {
  std::string file;              ///< --config FILE (YAML)
  std::vector<std::string> set;  ///< --set key=value, repeatable, applied after the file
};

/// Adds every input option to `sub`. `with_init`: calibrate and info take --init/--fiducials
/// (stitch takes an --extrinsic instead).
void add_input_options(CLI::App& sub, InputOptions& options, bool with_init = true);

/// Adds --config and --set.
void add_config_options(CLI::App& sub, ConfigOptions& options);

/// The defaults, then the --config file, then the --set assignments. Throws InputError.
ToolConfig load_config(const ConfigOptions& options);

/// What the options name, for io::load_input / io::input_kind.
io::InputSpec input_spec(const InputOptions& options);

/// The config's input section with the command line's overrides (--poses-columns).
io::InputConfig input_config(const InputOptions& options, io::InputConfig config);

/// io::load_input of what the options name. Throws InputError (exit 2): no input, several kinds,
/// an ambiguous or missing topic, a bad file, clocks nothing explains.
io::LoadedInput load_inputs(const InputOptions& options, const io::InputConfig& config);

}  // namespace insalign::cli
