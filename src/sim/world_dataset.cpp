#include "sim/world_dataset.hpp"

namespace insalign::sim {

Dataset world_dataset(std::shared_ptr<const World> world, std::size_t lidar) {
  const SimLidar& l = world->lidars.at(lidar);
  Dataset data;
  for (double t : l.frame_times_s) data.frames.frames.push_back({frame_name(t), t});
  data.frames.load = [world, lidar](std::size_t k) { return render_lidar_sweep(*world, lidar, k); };
  data.poses = PoseStream(frame_poses(*world, l.frame_times_s, lidar));
  data.ins_quality = ins_quality_series(*world, l.frame_times_s);
  data.fiducials = world->fiducials;
  data.T_ins_lidar_init = l.T_ins_lidar_init;
  return data;
}

}  // namespace insalign::sim
