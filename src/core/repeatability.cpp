#include "core/repeatability.hpp"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <initializer_list>
#include <optional>
#include <fmt/format.h>

namespace insalign {
namespace {

// The frames of the full run's selections whose time lies in [t0, t1).
struct SegmentFrames {
  FrameGroups groups;
  std::vector<std::size_t> refine;
};
SegmentFrames slice(const FrameStore& store, const RepeatabilityInputs& in, double t0, double t1) {
  const auto& frames = store.data().frames.frames;
  auto inside = [&](std::size_t i) { return frames[i].t_end_s >= t0 && frames[i].t_end_s < t1; };
  SegmentFrames out;
  for (const auto& g : in.rough_groups)
    if (inside(g.front())) out.groups.push_back(g);
  for (std::size_t i : in.refine_frames)
    if (inside(i)) out.refine.push_back(i);
  return out;
}

// Where a segment's stage 2 starts: the full run's result, or stage 1 on the segment's groups
// (the schedule's last rounds from the full result, the whole of it from the run's start, or the
// last round when the segment has no stage 2). nullopt: stage 1 failed (`message` says why).
std::optional<Iso3> segment_start(const FrameStore& store, const RepeatabilityInputs& in, const SegmentFrames& frames,
                                  const RoughConfig& rough_config, int rough_rounds, std::string& message) {
  if (rough_rounds == 0 && !frames.refine.empty()) return in.T_ins_lidar_full;
  RoughConfig own = rough_config;
  Iso3 start = in.T_ins_lidar_start;
  const std::size_t last = rough_rounds < 0 ? own.rounds.size() : static_cast<std::size_t>(std::max(rough_rounds, 1));
  if (last < own.rounds.size()) {
    own.rounds.erase(own.rounds.begin(), own.rounds.end() - static_cast<std::ptrdiff_t>(last));
    start = in.T_ins_lidar_full;
  }
  const RoughResult rough = calibrate_rough(store, frames.groups, start, in.time_offset_full_s, own);
  if (!rough.outcome.ok()) {
    message = rough.outcome.message;
    return std::nullopt;
  }
  return rough.T_ins_lidar;
}

SegmentResult calibrate_segment(const FrameStore& store, const RepeatabilityInputs& in, const SegmentFrames& frames,
                                const RoughConfig& rough_config, const RefineConfig& refine_config,
                                const RepeatabilityConfig& config) {
  SegmentResult out;
  const std::optional<Iso3> start = segment_start(store, in, frames, rough_config, config.rough_rounds, out.message);
  if (!start) return out;
  out.T_ins_lidar = *start;
  if (!frames.refine.empty()) {
    // The offset starts at the full run's: the coarse scan that finds it from afar (a third of a
    // segment's stage 2) would land there again.
    RefineConfig refine_own = refine_config;
    refine_own.time_offset_scan_step_s = 0.0;
    refine_own.extrinsic_only = true;
    std::string warning;  // the segments' spread is the verdict here
    const RefineResult refine = refine_checked(store, frames.refine, *start, in.time_offset_full_s,
                                               in.max_speed_mps, refine_own, {}, warning);
    if (!refine.outcome.ok()) {
      out.message = refine.outcome.message;
      return out;
    }
    out.T_ins_lidar = refine.T_ins_lidar;
    out.time_offset_s = refine.time_offset_s;
  }
  out.ok = true;
  return out;
}

std::string format_spread(const Vec6& spread) {
  return fmt::format("x {:.3g} cm, y {:.3g} cm, roll {:.3g} deg, pitch {:.3g} deg, yaw {:.3g} deg", spread[0] * 100,
                     spread[1] * 100, spread[3] * kDegPerRad, spread[4] * kDegPerRad, spread[5] * kDegPerRad);
}

// Spread over the successful segments, and the whole drive's sigma it implies.
void summarise(const RepeatabilityInputs& in, const RepeatabilityConfig& config, RepeatabilityResult& r) {
  Vec6 lo = Vec6::Constant(1e300), hi = Vec6::Constant(-1e300);
  double offset_lo = 1e300, offset_hi = -1e300;
  for (const SegmentResult& seg : r.segments) {
    if (!seg.ok) continue;
    ++r.segments_ok;
    offset_lo = std::min(offset_lo, seg.time_offset_s), offset_hi = std::max(offset_hi, seg.time_offset_s);
    Vec6 v;
    v.head<3>() = seg.T_ins_lidar.translation();
    v.tail<3>() = so3_log(seg.T_ins_lidar.linear() * in.T_ins_lidar_full.linear().transpose());
    lo = lo.cwiseMin(v);
    hi = hi.cwiseMax(v);
  }
  if (r.segments_ok < 2) {
    r.warning = "repeatability: fewer than two segments could be calibrated on their own";
    return;
  }
  r.spread = hi - lo;
  r.spread[2] = 0.0;
  for (int i : {0, 1, 3, 4, 5}) r.stddev_whole_drive[i] = r.spread[i] * whole_drive_stddev_per_spread(r.segments_ok);
  r.time_offset_stddev_whole_drive_s = (offset_hi - offset_lo) * whole_drive_stddev_per_spread(r.segments_ok);
  const bool large = r.spread.head<2>().maxCoeff() > config.warn_trans_m ||
                     r.spread.tail<3>().maxCoeff() > config.warn_rot_deg * kRadPerDeg;
  if (large) {
    r.warning = "segments of the drive disagree more than expected (" + format_spread(r.spread) +
                "): check for moving objects, INS quality or a loose mount";
  }
}

// The geometric mean of range-based stddevs from n segments falls short of sigma by this factor
// (exp E[log(range / d_n)] of n normal draws, by simulation): a pooled inflation is divided by it.
constexpr double kGeomeanOfRangeBias[] = {1.0, 1.0, 0.664, 0.843, 0.900, 0.926};

// The geometric mean over `dofs` of segments / formal, over the DOFs that have both (0: none).
double pooled_inflation(const Vec6& formal, const Vec6& segments, std::initializer_list<int> dofs) {
  double log_sum = 0.0;
  int n = 0;
  for (int i : dofs) {
    if (!(std::isfinite(segments[i]) && segments[i] > 0.0 && std::isfinite(formal[i]) && formal[i] > 0.0)) continue;
    log_sum += std::log(segments[i] / formal[i]);
    ++n;
  }
  return n > 0 ? std::exp(log_sum / n) : 0.0;
}

}  // namespace

double whole_drive_stddev_per_spread(int segments) {
  constexpr double kRangeFactor[] = {1.0, 1.0, 1.128, 1.693, 2.059, 2.326};  // d_n
  const int n = std::clamp(segments, 1, 5);
  return 1.0 / (kRangeFactor[n] * std::sqrt(double(n)));
}

namespace {

// How far the formal stddev falls short for the DOFs the turns determine (x, y, yaw) and for
// those the ground does (roll, pitch): the formal stddev is the more optimistic for the former
// (30-40x against 10-15x on 52 drives, bench/RESULTS.md), so each kind takes the larger of the
// drive's pooled inflation and its own, divided by the geometric mean's shortfall; at least 1.
struct Inflations {
  double turns = 1.0, ground = 1.0;
};
Inflations inflations(const Vec6& formal, const RepeatabilityResult& repeatability) {
  const Vec6& segments = repeatability.stddev_whole_drive;
  const double bias = kGeomeanOfRangeBias[std::clamp(repeatability.segments_ok, 0, 5)];
  const double drive = pooled_inflation(formal, segments, {0, 1, 3, 4, 5});
  return {std::max(1.0, std::max(drive, pooled_inflation(formal, segments, {0, 1, 5})) / bias),
          std::max(1.0, std::max(drive, pooled_inflation(formal, segments, {3, 4})) / bias)};
}

}  // namespace

Vec6 stddev_with_repeatability(const Vec6& formal, const RepeatabilityResult& repeatability) {
  return stddev_with_repeatability(formal, formal, repeatability);
}

Vec6 stddev_with_repeatability(const Vec6& formal, const Vec6& segments_formal, const RepeatabilityResult& repeatability) {
  const Vec6& segments = repeatability.stddev_whole_drive;
  const Inflations inflation = inflations(segments_formal, repeatability);
  Vec6 out = formal;
  for (int i : {0, 1, 3, 4, 5}) {
    if (!std::isfinite(segments[i])) continue;
    const double inflation_i = i == 3 || i == 4 ? inflation.ground : inflation.turns;
    const double widened = std::isfinite(segments_formal[i]) ? inflation_i * segments_formal[i] : 0.0;
    out[i] = std::max({std::isfinite(formal[i]) ? formal[i] : 0.0, segments[i], widened});
  }
  return out;
}

double time_offset_stddev_with_repeatability(double formal_s, const Vec6& formal, const RepeatabilityResult& repeatability) {
  if (!std::isfinite(formal_s) || !std::isfinite(repeatability.time_offset_stddev_whole_drive_s)) return formal_s;
  return std::max({formal_s, repeatability.time_offset_stddev_whole_drive_s, inflations(formal, repeatability).turns * formal_s});
}

double ground_inflation(const Vec6& formal, const RepeatabilityResult& repeatability) {
  return inflations(formal, repeatability).ground;
}

RepeatabilityResult run_repeatability(const FrameStore& store, const RepeatabilityInputs& inputs,
                                      const RoughConfig& rough, const RefineConfig& refine,
                                      const RepeatabilityConfig& config) {
  const auto start = std::chrono::steady_clock::now();
  RepeatabilityResult result;
  const auto& frames = store.data().frames.frames;
  if (config.segments < 2 || frames.empty()) return result;
  const std::size_t k = static_cast<std::size_t>(config.segments);
  result.segments.resize(k);
  tbb::parallel_for(std::size_t{0}, k, [&](std::size_t s) {
    const std::size_t begin = s * frames.size() / k, end = (s + 1) * frames.size() / k;
    SegmentResult& seg = result.segments[s];
    if (begin >= end) return;
    const double t0 = frames[begin].t_end_s;
    const double t1 = end < frames.size() ? frames[end].t_end_s : frames.back().t_end_s + 1.0;
    const SegmentFrames own = slice(store, inputs, t0, t1);
    seg = calibrate_segment(store, inputs, own, rough, refine, config);
    seg.t_begin_s = t0;
    seg.t_end_s = frames[end - 1].t_end_s;
    seg.frames = end - begin;
  });
  summarise(inputs, config, result);
  result.wall_time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

}  // namespace insalign
