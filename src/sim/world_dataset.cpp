#include "sim/world_dataset.hpp"

namespace insalign::sim {

Dataset world_dataset(std::shared_ptr<const World> world) {
  Dataset data;
  for (double t : world->frame_times_s) data.frames.frames.push_back({frame_name(t), t});
  data.frames.load = [world](std::size_t k) { return render_sweep(*world, k); };
  data.poses = PoseStream(frame_poses(*world, world->frame_times_s));
  data.ins_quality = ins_quality_series(*world, world->frame_times_s);
  data.fiducials = world->fiducials;
  data.T_ins_lidar_init = world->T_ins_lidar_init;
  return data;
}

}  // namespace insalign::sim
