#include "cli/input_options.hpp"

namespace insalign::cli {

void add_input_options(CLI::App& sub, InputOptions& o, bool with_init) {
  sub.add_option("--lidar-dir", o.lidar_dirs, "folder of PCD sweeps, one per frame; repeat for a rig (same --poses)");
  sub.add_option("--poses", o.poses,
                 "INS poses T_world_ins: OpenCalib, TUM, NovAtel ASCII, SBET, a text export or a KITTI oxts/ folder "
                 "(detected from the content)");
  sub.add_option("--poses-columns", o.poses_columns,
                 "text exports: the column mapping, e.g. \"time=GPSTime:gps-sow,lat=Latitude,...\" (see README)");
  sub.add_option("--bag", o.bag, "a recording: ROS 1 .bag, MCAP .mcap, rosbag2 .db3 or a rosbag2 folder");
  sub.add_option("--lidar-topic", o.lidar_topics,
                 "recordings: sensor_msgs/PointCloud2 topic (default: the only one); repeat for a rig");
  sub.add_option("--ins-topic", o.ins_topic, "recordings: INS topic (default: the preferred kind; \"FIX,IMU\" for a NavSatFix + Imu pair)");
  sub.add_option("--world-frame", o.world_frame, "recordings with TF: the fixed frame the INS moves in");
  sub.add_option("--ins-frame", o.ins_frame, "recordings with TF: the INS body frame (T_ins_lidar's ins)");
  sub.add_option("--kitti-raw", o.kitti_raw, "a KITTI raw drive folder (..._sync): velodyne_points, oxts, ../calib_imu_to_velo.txt");
  if (!with_init) return;
  sub.add_option("--init", o.inits, "initial extrinsic: OpenCalib JSON, extrinsic.json or any extrinsic file insalign writes; repeat in the LiDARs' order; optional");
  sub.add_option("--fiducials", o.fiducials, "surveyed points 'id x y z' (world frame) or '# wgs84' lat lon height, to fix tz");
}

void add_config_options(CLI::App& sub, ConfigOptions& o) {
  sub.add_option("--config", o.file, "YAML file setting any parameter (see 'insalign config --dump')");
  sub.add_option("--set", o.set, "key=value for any parameter, after --config (repeatable), e.g. input.clock.enabled=false");
}

ToolConfig load_config(const ConfigOptions& o) {
  ToolConfig config = o.file.empty() ? ToolConfig{} : load_tool_config(o.file);
  return o.set.empty() ? config : tool_config_with(o.set, "--set", config);
}

io::InputSpec input_spec(const InputOptions& o) {
  io::InputSpec spec;
  spec.lidar_dirs.assign(o.lidar_dirs.begin(), o.lidar_dirs.end());
  spec.poses = o.poses;
  spec.bag = o.bag;
  spec.lidar_topics = o.lidar_topics;
  if (!o.ins_topic.empty()) spec.ins_topic = o.ins_topic;
  spec.world_frame = o.world_frame, spec.ins_frame = o.ins_frame;
  spec.kitti_raw = o.kitti_raw;
  spec.inits.assign(o.inits.begin(), o.inits.end());
  if (!o.fiducials.empty()) spec.fiducials = o.fiducials;
  return spec;
}

io::InputConfig input_config(const InputOptions& o, io::InputConfig config) {
  if (!o.poses_columns.empty()) config.poses_columns = o.poses_columns;
  return config;
}

io::LoadedInput load_inputs(const InputOptions& o, const io::InputConfig& config) {
  return io::load_input(input_spec(o), input_config(o, config));
}

}  // namespace insalign::cli
