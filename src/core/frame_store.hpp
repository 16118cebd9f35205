// A run's sweeps, loaded and thinned once: every stage, the repeatability segments and the report
// read the same reduced copies instead of decoding a sweep again. Only the frames asked for are
// ever loaded, so a long drive costs no more memory than the frames the method picks.
#pragma once

#include <array>
#include <atomic>
#include <cstddef>
#include <memory>
#include <mutex>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "core/dataset.hpp"
#include "core/frames.hpp"

namespace insalign {

/// What was wrong in a left-out INS stretch, and who found it (core/ins_screen.hpp).
enum class SpanKind {
  kDegradedFix,     ///< the INS states a worse solution than the drive's usual (RTK float, single, ...)
  kInsOnly,         ///< no GNSS: the INS coasts on its inertial sensors
  kInvalid,         ///< the INS marks its solution unusable
  kLargeStddev,     ///< the INS states a standard deviation far above the drive's typical one
  kMotionMismatch,  ///< LiDAR scan-to-scan motion disagrees with the INS motion (a jump)
  kOffMap,          ///< the frames sit off the surfaces the rest of the drive agrees on
  kNotChosen,       ///< not an INS fault: `check` did not choose this stretch (core/stretches.hpp)
};
inline constexpr std::array<std::pair<SpanKind, std::string_view>, 7> kSpanKindNames{
    {{SpanKind::kDegradedFix, "degraded-fix"}, {SpanKind::kInsOnly, "ins-only"}, {SpanKind::kInvalid, "invalid"},
     {SpanKind::kLargeStddev, "large-stddev"}, {SpanKind::kMotionMismatch, "motion-mismatch"},
     {SpanKind::kOffMap, "off-map"}, {SpanKind::kNotChosen, "not-chosen"}}};
constexpr auto enum_names(SpanKind) { return std::span(kSpanKindNames); }

enum class SpanSource {
  kInsStatus,    ///< the INS's own solution status and stated standard deviations
  kLidarMotion,  ///< scan-to-scan registration against the INS motion
  kMapResidual,  ///< per-frame offset from the map of the rest of the drive
  kCheck,        ///< the check's choice of informative stretches
};
inline constexpr std::array<std::pair<SpanSource, std::string_view>, 4> kSpanSourceNames{
    {{SpanSource::kInsStatus, "ins-status"}, {SpanSource::kLidarMotion, "lidar-motion"},
     {SpanSource::kMapResidual, "map-residual"}, {SpanSource::kCheck, "check"}}};
constexpr auto enum_names(SpanSource) { return std::span(kSpanSourceNames); }

/// A span of INS time [begin, end] left out of the calibration (a bad INS stretch), and why.
struct TimeSpan {
  double begin_s = 0.0, end_s = 0.0;  ///< INS clock
  std::string reason;
  SpanKind kind = SpanKind::kDegradedFix;
  SpanSource source = SpanSource::kInsStatus;
};

/// The spans that blame the INS: every one but those `check` left out for its own reasons.
std::vector<TimeSpan> ins_spans(const std::vector<TimeSpan>& spans);

/// Which points of a frame the stages may use: points on things that moved are not (see
/// core/moving_points.hpp). Thread-safe.
class PointMask {
 public:
  virtual ~PointMask() = default;
  /// keep[i]: point i of `sweep` (frame `index`, as loaded or thinned), placed by the mask itself.
  virtual std::vector<char> keep(std::size_t index, const Sweep& sweep) const = 0;
  /// The same for points a stage has already placed in the world.
  virtual std::vector<char> keep_world(std::size_t index, const std::vector<Vec3f>& p_world) const = 0;
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
  /// The same frames whose thinned() copies leave out what `mask` drops (stage 3 asks it too).
  FrameStore with_mask(std::shared_ptr<const PointMask> mask) const;

  const Dataset& data() const { return *data_; }
  /// The INS trajectory every stage places sweeps with: the dataset's, or a corrected one.
  const PoseStream& poses() const { return *poses_; }
  const std::vector<TimeSpan>& excluded() const { return excluded_; }
  /// Whether [t0, t1] (INS clock) touches an excluded span.
  bool excluded(double t0_s, double t1_s) const;
  const FramesConfig& frames_config() const { return frames_; }
  const SweepFilter& base_filter() const { return base_; }
  double sweep_period_s() const { return period_s_; }
  /// nullptr: every point is used.
  const PointMask* mask() const { return mask_.get(); }

  /// The frame thinned by the base filter (positions and point times; intensities dropped),
  /// decoded on first use. Thread-safe; throws what the
  /// dataset's loader throws (and tries again on the next call).
  const Sweep& reduced(std::size_t index) const;
  /// Decodes the given frames now, in parallel (the checks after stage 1 sample decoded frames).
  void load(const std::vector<std::size_t>& indices) const;
  /// `filter` applied to the stored copies of the given frames, in parallel, then the mask.
  /// keep_decoded false: a frame not decoded yet is decoded for this call only, not stored (a step
  /// whose frames no later step reads: the trajectory correction's 240 beside stage 2's 120 raised
  /// the peak by ~230 MB).
  std::vector<Sweep> thinned(const std::vector<std::size_t>& indices, const SweepFilter& filter,
                             bool keep_decoded = true) const;

  /// Drops every decoded sweep but those of `keep` (readers decode them again if they ask): a
  /// step whose frames no later step takes gives its memory back. Not safe while another thread
  /// reads this store or a copy of it, nor with a reference from reduced() still held: call it
  /// between steps.
  void forget(const std::vector<std::size_t>& keep = {}) const;

  std::size_t frames_decoded() const { return cache_->decoded.load(); }
  /// Whether frame `index` is already decoded (readers that may pick any frame of a slice of the
  /// drive pick a decoded one: core/frames.hpp spread_over_motion).
  bool is_decoded(std::size_t index) const { return cache_->slots[index].done.load(std::memory_order_acquire); }

 private:
  Sweep decode_reduced(std::size_t index) const;  ///< the frame thinned by the base filter, not stored
  struct Slot {
    std::mutex decoding;
    std::unique_ptr<const Sweep> sweep;
    std::atomic<bool> done{false};  ///< sweep is set (read without the lock)
  };
  struct Cache {
    explicit Cache(std::size_t n) : slots(new Slot[n]) {}
    std::unique_ptr<Slot[]> slots;
    std::atomic<std::size_t> decoded{0};
  };
  const Dataset* data_;
  std::shared_ptr<const PoseStream> poses_;
  std::vector<TimeSpan> excluded_;
  std::shared_ptr<const PointMask> mask_;
  SweepFilter base_;
  FramesConfig frames_;
  double period_s_ = 0.1;
  std::shared_ptr<Cache> cache_;  ///< shared by copies made with with()
};

/// The base filter that serves every one of `filters`: the smallest voxel, the widest range.
SweepFilter finest_of(const std::vector<SweepFilter>& filters);

}  // namespace insalign
