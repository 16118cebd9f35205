// What an ordinary drive measures of an installed extrinsic: the calibration stages (core/
// pipeline.hpp) started from it on the drive's informative stretches (core/stretches.hpp), with
// the motion and observability gates opened so that a drive which sees only some degrees of
// freedom still reports them (each with its stddev; core/check.hpp judges them). Pure computation.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "core/check.hpp"
#include "core/check_history.hpp"
#include "core/pipeline.hpp"
#include "core/stretches.hpp"

namespace insalign {

/// A check's configuration beyond the pipeline's: the verdict rules and the stretch selection.
struct CheckRunConfig {
  CheckConfig check;
  StretchConfig stretches;
  HistoryConfig history;
  /// The pipeline's gates, opened for a check (a calibration refuses a drive that cannot determine
  /// every DOF; a check reports each DOF's stddev and lets the tolerance rule decide): the motion
  /// check's turn requirements are dropped (its minimum distance stays: a drive that barely moves
  /// determines nothing), and stage 1's noise and leverage limits widened by this factor.
  double gate_factor = 10.0;
  /// Frames stitched for the crispness figures at the installed and the corrected extrinsic.
  std::size_t crispness_frames = 40;
};

template <class V>
void visit_config(V& v, CheckRunConfig& c) {
  visit_config(v, c.check);
  v("gate_factor", c.gate_factor, "check: stage 1's noise and leverage limits widened by this factor (the verdict rule decides)");
  v("crispness_frames", c.crispness_frames, "check: frames stitched for the crispness at the installed and corrected extrinsic");
  v.section("stretches", c.stretches);
  v.section("history", c.history);
}

/// The pipeline configuration a check runs: `config` with the gates opened (see gate_factor).
PipelineConfig check_pipeline_config(PipelineConfig config, const CheckRunConfig& check);

struct CheckRun {
  std::vector<Stretch> used;                 ///< the stretches the stages read
  std::optional<CalibrationResult> result;   ///< unset: the drive determines nothing (why_unobservable)
  std::string why_unobservable;
  MeasuredExtrinsic measured;                ///< from result (the installed one with infinite stddevs if none)
  CheckFindings findings;
  /// Point-to-plane RMS of the stitched map (crispness_frames spread over the stretches), m: at the
  /// installed extrinsic and at the measured one (lower is crisper). NaN when not measured.
  double crispness_installed_m = std::numeric_limits<double>::quiet_NaN();
  double crispness_corrected_m = std::numeric_limits<double>::quiet_NaN();
  std::size_t frames_decoded = 0;
  std::size_t frames_total = 0;  ///< sweeps in the drive
  double wall_time_s = 0.0;
};

/// Runs the check on a store whose dataset's T_ins_lidar_init is the installed extrinsic (global
/// initialisation checks it against the data: a grossly wrong one, e.g. inverted, is replaced by
/// the data's own start and shows as a gross correction). Never throws for a degenerate drive.
CheckRun run_check(const FrameStore& store, const Iso3& T_ins_lidar_installed, double time_offset_installed_s,
                   const PipelineConfig& pipeline, const CheckRunConfig& config, const PipelineProgress& progress = {});

}  // namespace insalign
