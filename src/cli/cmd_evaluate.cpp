// insalign evaluate: the error of a calibration result against a simulated ground truth, in the
// INS frame as CONVENTIONS.md defines it; optional thresholds turn it into a pass/fail exit code.
#include <fmt/core.h>

#include <cmath>
#include <limits>
#include <optional>

#include "cli/commands.hpp"
#include "core/errors.hpp"
#include "core/geometry.hpp"
#include "files/extrinsic_json.hpp"

namespace insalign::cli {
namespace {

struct EvaluateOptions {
  std::string gt, result;
  double max_rot_deg = std::numeric_limits<double>::quiet_NaN();
  double max_trans_m = std::numeric_limits<double>::quiet_NaN();
  bool ignore_z = false;
};

int run_evaluate(const EvaluateOptions& o) {
  const io::ExtrinsicFile gt = io::read_extrinsic_file(o.gt);
  const io::ExtrinsicFile est = io::read_extrinsic_file(o.result);
  const ExtrinsicError e = extrinsic_error(est.T_ins_lidar, gt.T_ins_lidar);
  const double dt_checked_m = o.ignore_z ? e.dt_m.head<2>().norm() : e.dt_norm_m;

  fmt::print("extrinsic error (result vs ground truth, INS frame; absolute values)\n");
  fmt::print("  translation  dx {:.4f}  dy {:.4f}  dz {:.4f}  norm {:.4f} m{}\n", e.dt_m.x(), e.dt_m.y(), e.dt_m.z(),
             e.dt_norm_m, o.ignore_z ? fmt::format("  (xy norm {:.4f} m, z ignored)", dt_checked_m) : "");
  fmt::print("  rotation     roll {:.4f}  pitch {:.4f}  yaw {:.4f}  angle {:.4f} deg\n", e.drpy_deg.x(), e.drpy_deg.y(),
             e.drpy_deg.z(), e.angle_deg);
  if (gt.time_offset_s && est.time_offset_s) {
    fmt::print("  time offset  result {:.4f} s  truth {:.4f} s  error {:.4f} s\n", *est.time_offset_s,
               *gt.time_offset_s, std::abs(*est.time_offset_s - *gt.time_offset_s));
  } else if (gt.time_offset_s) {
    fmt::print("  time offset  not in the result (truth {:.4f} s)\n", *gt.time_offset_s);
  }

  bool pass = true;
  if (std::isfinite(o.max_rot_deg) && e.angle_deg > o.max_rot_deg) {
    fmt::print("FAIL: rotation error {:.4f} deg exceeds --max-rot-deg {}\n", e.angle_deg, o.max_rot_deg);
    pass = false;
  }
  if (std::isfinite(o.max_trans_m) && dt_checked_m > o.max_trans_m) {
    fmt::print("FAIL: translation error {:.4f} m exceeds --max-trans-m {}\n", dt_checked_m, o.max_trans_m);
    pass = false;
  }
  if (pass && (std::isfinite(o.max_rot_deg) || std::isfinite(o.max_trans_m))) fmt::print("PASS\n");
  return pass ? kExitOk : kExitOther;
}

}  // namespace

Command make_evaluate_command() {
  auto options = std::make_shared<EvaluateOptions>();
  Command command;
  command.setup = [options](CLI::App& app) {
    CLI::App* sub = app.add_subcommand("evaluate", "Error of a calibration result against a simulated ground truth");
    sub->add_option("--gt", options->gt, "ground_truth.json written by `insalign simulate`")->required();
    sub->add_option("--result", options->result, "OUT_DIR/extrinsic.json written by `insalign calibrate`")->required();
    sub->add_option("--max-rot-deg", options->max_rot_deg, "exit 1 if the rotation error angle exceeds this")
        ->check(CLI::NonNegativeNumber);
    sub->add_option("--max-trans-m", options->max_trans_m, "exit 1 if the translation error norm exceeds this")
        ->check(CLI::NonNegativeNumber);
    sub->add_flag("--ignore-z", options->ignore_z, "leave z out of the translation threshold (no fiducials)");
    return sub;
  };
  command.run = [options] { return run_evaluate(*options); };
  return command;
}

}  // namespace insalign::cli
