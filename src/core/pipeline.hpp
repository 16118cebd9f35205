// The whole calibration: motion check, start (global initialisation or a checked --init),
// stage 1 (rough), stage 2 (refine + time offset), stage 3 (z), and a repeatability study on
// disjoint segments of the drive. Pure computation: the command line loads and writes.
#pragma once

#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "core/dataset.hpp"
#include "core/global_init.hpp"
#include "core/motion_check.hpp"
#include "core/observability.hpp"
#include "core/refine.hpp"
#include "core/rough.hpp"
#include "core/zcorrect.hpp"

namespace insalign {

struct PipelineConfig {
  MotionCheckConfig motion;
  GlobalInitConfig init;
  RoughConfig rough;
  RefineConfig refine;
  ZConfig z;
  bool run_refine = true;                  ///< stage 2 (false: stop after stage 1)
  /// Stage 2 may move the horizontal lever arm by max speed x its time-offset change plus this
  /// (stage 1's accuracy bound); beyond, it is run again with the offset fixed (pipeline.cpp).
  double refine_max_unexplained_shift_m = 0.03;
  std::optional<double> ins_height_m;      ///< INS origin height above the ground, for stage 3
  /// Disjoint time segments of the drive calibrated on their own (stages 1 and 2, from the same
  /// start) to show the spread of the result without ground truth; 0 or 1 = off.
  int repeatability_segments = 3;
  /// A segment spread above these (max - min over segments) is a warning.
  double repeatability_warn_rot_deg = 0.1;
  double repeatability_warn_trans_m = 0.02;
};

/// One segment of the repeatability study.
struct SegmentResult {
  double t_begin_s = 0.0, t_end_s = 0.0;  ///< LiDAR clock
  std::size_t frames = 0;
  bool ok = false;                        ///< false: the segment alone could not be calibrated
  std::string message;                    ///< why not
  Iso3 T_ins_lidar = Iso3::Identity();
  double time_offset_s = 0.0;
};

struct CalibrationResult {
  MotionCheck motion;
  GlobalInitResult init;
  RoughResult rough;
  std::optional<RefineResult> refine;
  ZResult z;
  Iso3 T_ins_lidar = Iso3::Identity();  ///< final estimate
  double time_offset_s = 0.0;           ///< t_ins = t_lidar + time_offset_s
  /// Final verdict per DOF [tx ty tz roll pitch yaw]: tz determined only by stage 3.
  std::array<bool, 6> determined{};
  /// m, deg: the larger of the formal value (stage information) and, with the repeatability
  /// study, the segments' spread scaled to the whole drive.
  Vec6 stddev = Vec6::Constant(std::numeric_limits<double>::quiet_NaN());
  std::vector<SegmentResult> segments;
  Vec6 segment_spread = Vec6::Zero();   ///< max - min over segments that succeeded, m / deg
  std::vector<std::string> warnings;
  double wall_time_s = 0.0;
};

/// step: a short name ("rough", "refine", ...); fraction of that step done in [0, 1].
using PipelineProgress = std::function<void(std::string_view step, double fraction)>;

/// Runs everything. Throws UnobservableError (with which DOFs and why) when the drive cannot
/// determine the extrinsic; tz alone undetermined is not an error (it is reported).
CalibrationResult run_calibration(const Dataset& data, const PipelineConfig& config,
                                  const PipelineProgress& progress = {});

/// The frames [begin, end) of a dataset as a dataset of their own (same poses and fiducials).
Dataset frame_subset(const Dataset& data, std::size_t begin, std::size_t end);

}  // namespace insalign
