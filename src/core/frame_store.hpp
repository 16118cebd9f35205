// A run's sweeps, loaded and thinned once: every stage, the repeatability segments and the report
// read the same reduced copies instead of decoding a sweep again. Only the frames asked for are
// ever loaded, so a long drive costs no more memory than the frames the method picks.
#pragma once

#include <atomic>
#include <cstddef>
#include <memory>
#include <mutex>
#include <vector>

#include "core/dataset.hpp"
#include "core/frames.hpp"

namespace insalign {

class FrameStore {
 public:
  /// base: the finest thinning any reader of the store needs; readers thin further with their own
  /// filters (thinned()). The dataset must outlive the store.
  FrameStore(const Dataset& data, const SweepFilter& base, const FramesConfig& frames = {});

  const Dataset& data() const { return *data_; }
  const PoseStream& poses() const { return data_->poses; }
  const FramesConfig& frames_config() const { return frames_; }
  const SweepFilter& base_filter() const { return base_; }
  double sweep_period_s() const { return period_s_; }

  /// The frame thinned by the base filter, decoded on first use. Thread-safe; throws what the
  /// dataset's loader throws (and tries again on the next call).
  const Sweep& reduced(std::size_t index) const;
  /// `filter` applied to the stored copies of the given frames, in parallel.
  std::vector<Sweep> thinned(const std::vector<std::size_t>& indices, const SweepFilter& filter) const;

  std::size_t frames_decoded() const { return decoded_.load(); }

 private:
  struct Slot {
    std::once_flag once;
    std::unique_ptr<const Sweep> sweep;
  };
  const Dataset* data_;
  SweepFilter base_;
  FramesConfig frames_;
  double period_s_ = 0.1;
  std::unique_ptr<Slot[]> slots_;
  mutable std::atomic<std::size_t> decoded_{0};
};

/// The base filter that serves every one of `filters`: the smallest voxel, the widest range.
SweepFilter finest_of(const std::vector<SweepFilter>& filters);

}  // namespace insalign
