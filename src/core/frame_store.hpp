// A run's sweeps, loaded and thinned once: every stage, the repeatability segments and the report
// read the same reduced copies instead of decoding a sweep again. Only the frames asked for are
// ever loaded, so a long drive costs no more memory than the frames the method picks.
#pragma once

#include <atomic>
#include <cstddef>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "core/dataset.hpp"
#include "core/frames.hpp"

namespace insalign {

/// A span of INS time [begin, end] left out of the calibration (a bad INS stretch), and why.
struct TimeSpan {
  double begin_s = 0.0, end_s = 0.0;  ///< INS clock
  std::string reason;
};

class FrameStore {
 public:
  /// base: the finest thinning any reader of the store needs; readers thin further with their own
  /// filters (thinned()). The dataset must outlive the store (and every copy of it).
  FrameStore(const Dataset& data, const SweepFilter& base, const FramesConfig& frames = {});

  /// The same frames (sharing what was already decoded) placed with other poses (a corrected
  /// INS trajectory) and with INS time spans left out (frames whose sweep touches one are not
  /// offered to any stage).
  FrameStore with(PoseStream poses, std::vector<TimeSpan> excluded) const;

  const Dataset& data() const { return *data_; }
  /// The INS trajectory every stage places sweeps with: the dataset's, or a corrected one.
  const PoseStream& poses() const { return *poses_; }
  const std::vector<TimeSpan>& excluded() const { return excluded_; }
  /// Whether [t0, t1] (INS clock) touches an excluded span.
  bool excluded(double t0_s, double t1_s) const;
  const FramesConfig& frames_config() const { return frames_; }
  const SweepFilter& base_filter() const { return base_; }
  double sweep_period_s() const { return period_s_; }

  /// The frame thinned by the base filter, decoded on first use. Thread-safe; throws what the
  /// dataset's loader throws (and tries again on the next call).
  const Sweep& reduced(std::size_t index) const;
  /// `filter` applied to the stored copies of the given frames, in parallel.
  std::vector<Sweep> thinned(const std::vector<std::size_t>& indices, const SweepFilter& filter) const;

  std::size_t frames_decoded() const { return cache_->decoded.load(); }

 private:
  struct Slot {
    std::once_flag once;
    std::unique_ptr<const Sweep> sweep;
  };
  struct Cache {
    explicit Cache(std::size_t n) : slots(new Slot[n]) {}
    std::unique_ptr<Slot[]> slots;
    std::atomic<std::size_t> decoded{0};
  };
  const Dataset* data_;
  std::shared_ptr<const PoseStream> poses_;
  std::vector<TimeSpan> excluded_;
  SweepFilter base_;
  FramesConfig frames_;
  double period_s_ = 0.1;
  std::shared_ptr<Cache> cache_;  ///< shared by copies made with with()
};

/// The base filter that serves every one of `filters`: the smallest voxel, the widest range.
SweepFilter finest_of(const std::vector<SweepFilter>& filters);

}  // namespace insalign
