#include "inslog/ins_track.hpp"

#include <cmath>

namespace insalign::io {

WorldTrack to_world(const InsTrack& track, const std::optional<GeodeticPoint>& origin) {
  WorldTrack out;
  out.poses.reserve(track.records.size());
  out.quality.reserve(track.records.size());
  if (track.geodetic && !track.records.empty()) {
    const InsRecord& first = track.records.front();
    out.enu.emplace(origin.value_or(GeodeticPoint{first.lat_deg, first.lon_deg, first.height_m}));
  }
  for (const InsRecord& r : track.records) {
    StampedPose pose;
    pose.t_s = r.t_s;
    if (out.enu) {
      const GeodeticPoint p{r.lat_deg, r.lon_deg, r.height_m};
      pose.T_world_ins.translation() = out.enu->position(p);
      pose.T_world_ins.linear() = out.enu->rotation_at(p) * r.R_world_ins;
    } else {
      pose.T_world_ins.translation() = r.p_world_m;
      pose.T_world_ins.linear() = r.R_world_ins;
    }
    out.poses.push_back(pose);
    InsQuality q;
    q.t_s = r.t_s;
    q.solution = r.solution;
    q.horizontal_stddev_m = r.position_stddev_m.head<2>().norm();
    q.vertical_stddev_m = r.position_stddev_m.z();
    out.quality.push_back(q);
  }
  return out;
}

}  // namespace insalign::io
