#include "core/frame_store.hpp"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <iterator>

namespace insalign {
namespace {

// The sweep without the points keep[i] == 0 drops (every per-point field alike).
Sweep kept_points(const Sweep& sweep, const std::vector<char>& keep) {
  Sweep out;
  out.name = sweep.name;
  out.t_end_s = sweep.t_end_s;
  for (std::size_t i = 0; i < sweep.size(); ++i) {
    if (!keep[i]) continue;
    out.p_lidar.push_back(sweep.p_lidar[i]);
    if (sweep.has_time()) out.dt_s.push_back(sweep.dt_s[i]);
    if (!sweep.intensity.empty()) out.intensity.push_back(sweep.intensity[i]);
    if (!sweep.ring.empty()) out.ring.push_back(sweep.ring[i]);
  }
  return out;
}

}  // namespace

FrameStore::FrameStore(const Dataset& data, const SweepFilter& base, const FramesConfig& frames)
    : data_(&data),
      poses_(std::shared_ptr<const PoseStream>(std::shared_ptr<const PoseStream>{}, &data.poses)),
      base_(base),
      frames_(frames),
      period_s_(insalign::sweep_period_s(data.frames.frames, frames)),
      cache_(std::make_shared<Cache>(data.frames.frames.size())) {}

FrameStore FrameStore::with(PoseStream poses, std::vector<TimeSpan> excluded) const {
  FrameStore out = *this;
  out.poses_ = std::make_shared<const PoseStream>(std::move(poses));
  out.excluded_ = std::move(excluded);
  return out;
}

FrameStore FrameStore::with_mask(std::shared_ptr<const PointMask> mask) const {
  FrameStore out = *this;
  out.mask_ = std::move(mask);
  return out;
}

bool FrameStore::excluded(double t0_s, double t1_s) const {
  for (const TimeSpan& span : excluded_)
    if (t1_s >= span.begin_s && t0_s <= span.end_s) return true;
  return false;
}

const Sweep& FrameStore::reduced(std::size_t index) const {
  Slot& slot = cache_->slots[index];
  if (slot.done.load(std::memory_order_acquire)) return *slot.sweep;
  const std::lock_guard<std::mutex> lock(slot.decoding);
  if (!slot.sweep) {  // a loader that throws leaves it empty: the next call tries again
    slot.sweep = std::make_unique<const Sweep>(decode_reduced(index));
    slot.done.store(true, std::memory_order_release);
  }
  return *slot.sweep;
}

Sweep FrameStore::decode_reduced(std::size_t index) const {
  Sweep sweep = thin_sweep(data_->frames.load(index), base_);
  // No stage reads intensities: a fifth less memory per stored point (12 B position + 4 B time).
  sweep.intensity = {};
  ++cache_->decoded;
  return sweep;
}

void FrameStore::forget(const std::vector<std::size_t>& keep) const {
  std::vector<char> kept(data_->frames.frames.size(), 0);
  for (std::size_t i : keep) kept.at(i) = 1;
  for (std::size_t i = 0; i < kept.size(); ++i) {
    Slot& slot = cache_->slots[i];
    if (kept[i] || !slot.done.load(std::memory_order_acquire)) continue;
    slot.done.store(false, std::memory_order_release);
    slot.sweep.reset();
  }
  // The freed memory stays in the process (cli/main.cpp): the next step's sweeps reuse it without
  // page faults, and the peak does not grow (handing it back with malloc_trim cost 0.2 s a run).
}

void FrameStore::load(const std::vector<std::size_t>& indices) const {
  tbb::parallel_for(std::size_t{0}, indices.size(), [&](std::size_t k) { reduced(indices[k]); });
}

std::vector<Sweep> FrameStore::thinned(const std::vector<std::size_t>& indices, const SweepFilter& filter,
                                       bool keep_decoded) const {
  // The stored copies keep one point per cube of the base edge already: the same edge again
  // would keep every point, so that pass is skipped (the range and the budget still apply).
  SweepFilter own = filter;
  if (own.voxel_m == base_.voxel_m) own.voxel_m = 0.0;
  std::vector<Sweep> out(indices.size());
  tbb::parallel_for(std::size_t{0}, indices.size(),
                    [&](std::size_t k) {
                      const std::size_t i = indices[k];
                      out[k] = keep_decoded || is_decoded(i) ? thin_sweep(reduced(i), own)
                                                             : thin_sweep(decode_reduced(i), own);
                      if (mask_) out[k] = kept_points(out[k], mask_->keep(indices[k], out[k]));
                    });
  return out;
}

std::vector<TimeSpan> ins_spans(const std::vector<TimeSpan>& spans) {
  std::vector<TimeSpan> out;
  std::copy_if(spans.begin(), spans.end(), std::back_inserter(out),
               [](const TimeSpan& s) { return s.kind != SpanKind::kNotChosen; });
  return out;
}

SweepFilter finest_of(const std::vector<SweepFilter>& filters) {
  SweepFilter out;
  if (filters.empty()) return out;
  out = filters.front();
  out.max_points = 0;  // budgets are per reader
  for (const SweepFilter& f : filters) {
    out.min_range_m = std::min(out.min_range_m, f.min_range_m);
    out.max_range_m = std::max(out.max_range_m, f.max_range_m);
    out.voxel_m = std::min(out.voxel_m, f.voxel_m);
  }
  return out;
}

}  // namespace insalign
