// check.html's 3D view: the drive's map at the installed extrinsic and at the corrected one, the
// stretches the check used in colour, the rest of the drive grey for context (report/viewer.hpp).
#include <algorithm>

#include "core/stitch.hpp"
#include "core/stretches.hpp"
#include "report/check_outputs.hpp"

namespace insalign::io {
namespace {

// The check's crispness frames are these many; the view shows the same number in its stretches
// and half as many beyond them (where the drive goes on, e.g. the same street driven again).
constexpr std::size_t kFramesInStretches = 40, kFramesOutside = 20;

std::vector<std::size_t> check_view_frames(const FrameStore& store, const CheckRun& run, double time_offset_s) {
  std::vector<std::size_t> frames = spread_frames(keep_stretches(store, run.used), kFramesInStretches, time_offset_s);
  for (std::size_t k : spread_frames(store, kFramesInStretches + kFramesOutside, time_offset_s))
    if (std::find(frames.begin(), frames.end(), k) == frames.end() && frames.size() < kFramesInStretches + kFramesOutside)
      frames.push_back(k);
  std::sort(frames.begin(), frames.end());
  return frames;
}

}  // namespace

ViewerScene check_viewer_scene(const FrameStore& store, const CheckRun& run, const Iso3& T_ins_lidar_installed,
                               double time_offset_installed_s, const ViewerConfig& config) {
  if (config.max_points == 0) return {};
  const CorrectedExtrinsic c = corrected_extrinsic(T_ins_lidar_installed, time_offset_installed_s, run.findings.dofs);
  const std::vector<std::size_t> frames = check_view_frames(store, run, c.time_offset_s);
  const std::vector<TimeSpan> excluded = run.result ? run.result->excluded : std::vector<TimeSpan>{};
  const PointMask* mask = run.result ? run.result->moving.mask.get() : nullptr;
  ViewerScene scene = viewer_scene(store, frames, {{"installed", T_ins_lidar_installed, time_offset_installed_s},
                                                   {"corrected", c.T_ins_lidar, c.time_offset_s}},
                                   excluded, mask, config);
  std::vector<TimeSpan> used;
  for (const Stretch& s : run.used) used.push_back({s.begin_s, s.end_s, s.why});
  if (!used.empty()) mark_outside(scene, used, store.sweep_period_s(), c.time_offset_s);
  scene.fallback = "the verdict and the table above say what the drive measured.";
  return scene;
}

}  // namespace insalign::io
