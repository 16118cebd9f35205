#include "core/frame_store.hpp"

#include <tbb/parallel_for.h>

#include <algorithm>

namespace insalign {

FrameStore::FrameStore(const Dataset& data, const SweepFilter& base, const FramesConfig& frames)
    : data_(&data),
      base_(base),
      frames_(frames),
      period_s_(insalign::sweep_period_s(data.frames.frames, frames)),
      slots_(new Slot[data.frames.frames.size()]) {}

const Sweep& FrameStore::reduced(std::size_t index) const {
  Slot& slot = slots_[index];
  std::call_once(slot.once, [&] {
    slot.sweep = std::make_unique<const Sweep>(thin_sweep(data_->frames.load(index), base_));
    ++decoded_;
  });
  return *slot.sweep;
}

std::vector<Sweep> FrameStore::thinned(const std::vector<std::size_t>& indices, const SweepFilter& filter) const {
  std::vector<Sweep> out(indices.size());
  tbb::parallel_for(std::size_t{0}, indices.size(),
                    [&](std::size_t k) { out[k] = thin_sweep(reduced(indices[k]), filter); });
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
