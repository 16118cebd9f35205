#include "core/coarse_time_offset.hpp"

#include <algorithm>
#include <cmath>
#include <fmt/format.h>
#include <limits>

namespace insalign {
namespace {

// Median |LiDAR - INS angle| over the pairs the poses cover at this offset (NaN: too few).
double median_difference_deg(const std::vector<AnglePair>& pairs, const PoseStream& poses, double offset_s,
                             std::size_t min_pairs) {
  std::vector<double> d;
  for (const AnglePair& p : pairs) {
    const double ins_deg = rotation_angle_deg(poses, p.t0_s + offset_s, p.t1_s + offset_s);
    if (std::isfinite(ins_deg)) d.push_back(std::abs(p.lidar_deg - ins_deg));
  }
  if (d.size() < std::max<std::size_t>(min_pairs, 1)) return std::numeric_limits<double>::quiet_NaN();
  const auto mid = d.begin() + static_cast<std::ptrdiff_t>(d.size() / 2);
  std::nth_element(d.begin(), mid, d.end());
  return *mid;
}

}  // namespace

CoarseTimeOffset fit_time_offset(const std::vector<AnglePair>& pairs, const PoseStream& poses,
                                 const CoarseTimeOffsetConfig& config, double reference_s) {
  CoarseTimeOffset out;
  out.offset_s = out.best_offset_s = reference_s;
  out.pairs = pairs.size();
  if (config.range_s <= 0.0 || config.step_s <= 0.0 || pairs.size() < config.min_pairs) {
    out.explanation = fmt::format("time offset: not searched ({} registered pairs)", pairs.size());
    return out;
  }
  out.median_at_reference_deg = median_difference_deg(pairs, poses, reference_s, config.min_pairs);
  const int n = static_cast<int>(std::floor(config.range_s / config.step_s + 1e-9));
  double best = std::numeric_limits<double>::infinity();
  for (int i = -n; i <= n; ++i) {
    const double offset = reference_s + i * config.step_s;
    const double m = median_difference_deg(pairs, poses, offset, config.min_pairs);
    // Ties go to the offset nearest the reference.
    if (m < best || (m == best && std::abs(offset - reference_s) < std::abs(out.best_offset_s - reference_s)))
      best = m, out.best_offset_s = offset;
  }
  out.median_at_best_deg = best;
  const bool far = std::abs(out.best_offset_s - reference_s) >= config.min_offset_s;
  const bool clear = std::isfinite(best) && std::isfinite(out.median_at_reference_deg) &&
                     out.median_at_reference_deg >= config.min_gain * best &&
                     out.median_at_reference_deg - best >= config.min_gain_deg;
  out.applied = far && clear;
  out.offset_s = out.applied ? out.best_offset_s : reference_s;
  out.explanation = fmt::format(
      "time offset from the rotation angles of {} pairs: best {:+.3f} s (median |LiDAR - INS angle| {:.3f} deg, at "
      "{:+.3f} s {:.3f} deg): {}",
      pairs.size(), out.best_offset_s, best, reference_s, out.median_at_reference_deg,
      out.applied ? "taken (stage 2 refines it)"
                  : (far ? fmt::format("not clear enough, {:+.3f} s kept (stage 2 searches +-its range)", reference_s)
                         : "left to stage 2"));
  return out;
}

}  // namespace insalign
