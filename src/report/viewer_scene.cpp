// The viewer's scene: the same points of the report's frames placed at each extrinsic, decimated
// to the point budget, each tagged with its frame and why it was left out (if it was).
#include <tbb/parallel_for.h>

#include <algorithm>

#include "core/deskew.hpp"
#include "report/viewer.hpp"

namespace insalign::io {
namespace {

// Whether the sweep ending at t_end_s (LiDAR clock) touches a span (INS clock).
bool touches(const std::vector<TimeSpan>& spans, double t_end_s, double period_s, double time_offset_s) {
  const double t1 = t_end_s + time_offset_s, t0 = t1 - period_s;
  return std::any_of(spans.begin(), spans.end(), [&](const TimeSpan& s) { return s.begin_s <= t1 && s.end_s >= t0; });
}

// One frame's kept points (every `stride`-th, counting from `first` over the whole scene).
struct PlacedFrame {
  std::vector<std::vector<Vec3f>> p_world;  // [placing][point]
  std::vector<ViewerPointClass> point_class;
  bool covered = false;
};

PlacedFrame place(const FrameStore& store, std::size_t index, const std::vector<ViewerPlacing>& placings,
                  const std::vector<TimeSpan>& excluded, const PointMask* mask, std::size_t first, std::size_t stride) {
  PlacedFrame out;
  const Sweep& sweep = store.reduced(index);
  for (const ViewerPlacing& p : placings)
    if (!sweep_covered(store.poses(), sweep, p.time_offset_s)) return out;
  out.covered = true;
  const bool bad_ins = touches(excluded, sweep.t_end_s, store.sweep_period_s(), placings.back().time_offset_s);
  const std::vector<char> keep = mask && !bad_ins ? mask->keep(index, sweep) : std::vector<char>{};
  std::vector<std::size_t> picked;
  for (std::size_t i = (stride - first % stride) % stride; i < sweep.size(); i += stride) picked.push_back(i);
  for (std::size_t i : picked) {
    out.point_class.push_back(bad_ins ? ViewerPointClass::kBadIns
                              : !keep.empty() && !keep[i] ? ViewerPointClass::kMoving : ViewerPointClass::kUsed);
  }
  for (const ViewerPlacing& p : placings) {
    const std::vector<Vec3f> all = sweep_to_world(sweep, store.poses(), p.T_ins_lidar, PlaceOptions{.time_offset_s = p.time_offset_s});
    std::vector<Vec3f>& kept = out.p_world.emplace_back();
    kept.reserve(picked.size());
    for (std::size_t i : picked) kept.push_back(all[i]);
  }
  return out;
}

}  // namespace

ViewerScene viewer_scene(const FrameStore& store, const std::vector<std::size_t>& frames,
                         const std::vector<ViewerPlacing>& placings, const std::vector<TimeSpan>& excluded,
                         const PointMask* mask, const ViewerConfig& config) {
  ViewerScene scene;
  for (const ViewerPlacing& p : placings) scene.extrinsic_labels.push_back(p.label);
  scene.p_world.resize(placings.size());
  scene.lidar_names = {"lidar"};
  for (const StampedPose& pose : store.poses().poses()) scene.trajectory_world.push_back(pose.T_world_ins.translation());
  scene.fiducials = store.data().fiducials;
  if (config.max_points == 0 || placings.empty()) return scene;
  store.load(frames);  // decoded in parallel; the counts decide the stride
  std::vector<std::size_t> first(frames.size() + 1, 0);
  for (std::size_t k = 0; k < frames.size(); ++k) first[k + 1] = first[k] + store.reduced(frames[k]).size();
  const std::size_t stride = std::max<std::size_t>(1, (first.back() + config.max_points - 1) / config.max_points);
  std::vector<PlacedFrame> placed(frames.size());
  tbb::parallel_for(std::size_t{0}, frames.size(), [&](std::size_t k) {
    placed[k] = place(store, frames[k], placings, excluded, mask, first[k], stride);
  });
  for (std::size_t k = 0; k < frames.size(); ++k) {
    if (!placed[k].covered) continue;
    const Sweep& sweep = store.reduced(frames[k]);
    scene.points_total += sweep.size();
    const auto frame = static_cast<std::uint32_t>(scene.frames.size());
    scene.frames.push_back({sweep.name, sweep.t_end_s});
    for (std::size_t e = 0; e < placings.size(); ++e)
      scene.p_world[e].insert(scene.p_world[e].end(), placed[k].p_world[e].begin(), placed[k].p_world[e].end());
    scene.point_class.insert(scene.point_class.end(), placed[k].point_class.begin(), placed[k].point_class.end());
    scene.frame.insert(scene.frame.end(), placed[k].point_class.size(), frame);
  }
  scene.lidar.assign(scene.frame.size(), 0);
  return scene;
}

void mark_outside(ViewerScene& scene, const std::vector<TimeSpan>& inside, double period_s, double time_offset_s) {
  std::vector<char> outside(scene.frames.size());
  for (std::size_t f = 0; f < scene.frames.size(); ++f) {
    const double t1 = scene.frames[f].t_s + time_offset_s, t0 = t1 - period_s;
    outside[f] = std::none_of(inside.begin(), inside.end(), [&](const TimeSpan& s) { return s.begin_s <= t0 && t1 <= s.end_s; });
  }
  if (scene.point_class.empty()) scene.point_class.assign(scene.size(), ViewerPointClass::kUsed);
  for (std::size_t i = 0; i < scene.size(); ++i)
    if (outside[scene.frame[i]]) scene.point_class[i] = ViewerPointClass::kOutside;
}

ViewerScene merge_scenes(std::vector<ViewerScene> scenes, const std::vector<std::string>& lidar_names) {
  ViewerScene out;
  if (scenes.empty()) return out;
  out.extrinsic_labels = scenes.front().extrinsic_labels;
  out.p_world.resize(out.extrinsic_labels.size());
  out.lidar_names = lidar_names;
  out.trajectory_world = std::move(scenes.front().trajectory_world);
  out.fiducials = std::move(scenes.front().fiducials);
  for (std::size_t l = 0; l < scenes.size(); ++l) {
    ViewerScene& s = scenes[l];
    const auto frame0 = static_cast<std::uint32_t>(out.frames.size());
    out.frames.insert(out.frames.end(), s.frames.begin(), s.frames.end());
    for (std::size_t e = 0; e < out.p_world.size() && e < s.p_world.size(); ++e)
      out.p_world[e].insert(out.p_world[e].end(), s.p_world[e].begin(), s.p_world[e].end());
    for (std::uint32_t f : s.frame) out.frame.push_back(frame0 + f);
    out.lidar.insert(out.lidar.end(), s.size(), static_cast<std::uint8_t>(l));
    if (s.point_class.empty()) s.point_class.assign(s.size(), ViewerPointClass::kUsed);
    out.point_class.insert(out.point_class.end(), s.point_class.begin(), s.point_class.end());
    out.sections.insert(out.sections.end(), s.sections.begin(), s.sections.end());
    out.points_total += s.points_total;
  }
  return out;
}

}  // namespace insalign::io
