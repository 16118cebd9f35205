#include "core/dof_status.hpp"

#include <cmath>
#include <fmt/format.h>
#include <fmt/ranges.h>

#include "core/stage.hpp"

namespace insalign {
namespace {

bool from_absolute_reference(TzSource s) { return s == TzSource::kFiducials || s == TzSource::kInsHeight; }

std::string tz_sentence(const DofEvidence& e) {
  std::string s = fmt::format("tz is not determined: it is {}'s value ({:.3f} m)", tz_source_phrase(e.tz_source), e.tz_m);
  if (e.tz_source == TzSource::kData)
    s = fmt::format("tz is not determined: the drive's roll and pitch put it at {:.3f} m, but too loosely (+- {:.3f} m)",
                    e.tz_m, e.stddev[2]);
  if (e.tz_assumed_sigma_m > 0.0 && e.tz_source != TzSource::kData) s += fmt::format(", +- {:.2f} m assumed", e.tz_assumed_sigma_m);
  if (e.tz_assumed_sigma_m > 0.0)
    s += fmt::format("; x and y move {:.1f}, {:.1f} mm per 0.1 m of tz on this drive and their "
                     "stddev includes that",
                     1e2 * std::abs(e.dx_per_tz), 1e2 * std::abs(e.dy_per_tz));
  return s + ". Add fiducials (--fiducials) or give the INS height above the ground (--ins-height-m) to fix it.";
}

// Why a determined DOF is loose, and what would tighten it.
std::string weak_sentence(int i, double stddev, const DofEvidence& e) {
  const bool trans = i < 3;
  const std::string amount = trans ? fmt::format("+- {:.1f} cm", 1e2 * stddev) : fmt::format("+- {:.3f} deg", stddev * kDegPerRad);
  const double per_tz = i == 0 ? e.dx_per_tz : i == 1 ? e.dy_per_tz : 0.0;
  std::string what;
  if (e.tz_assumed_sigma_m > 0.0 && std::abs(per_tz) * e.tz_assumed_sigma_m > 0.5 * stddev)
    what = "most of it is tz's uncertainty: add fiducials or give --ins-height-m";
  else if (e.ins_drift_stddev[i] > 0.5 * stddev)
    what = "most of it is the INS's slow position error, which the trajectory correction measured: check the INS's "
           "RTK status (fixed, not float), or drive with RTK fixed throughout";
  else if (i == 3 || i == 4)
    what = "drive more turns on open, level ground (a figure-8 in both directions)";
  else
    what = "drive more turns (figure-8s in both directions, at different speeds)";
  return fmt::format("{} is weakly determined ({}): {}.", kDofNames[static_cast<std::size_t>(i)], amount, what);
}

}  // namespace

std::string tz_source_phrase(TzSource source) {
  switch (source) {
    case TzSource::kFiducials: return "the fiducials";
    case TzSource::kInsHeight: return "the ground under the INS and --ins-height-m";
    case TzSource::kData: return "the drive's roll and pitch";
    case TzSource::kInit: return "the --init file";
    case TzSource::kInsHeightGiven: return "--ins-height-m (as the start's INS height)";
    case TzSource::kGuess: return "the built-in guess (init.ins_height_guess_m, INS height above the ground)";
  }
  return "?";
}

std::array<bool, 6> DofStatusResult::determined() const {
  std::array<bool, 6> out{};
  for (std::size_t i = 0; i < 6; ++i) out[i] = dofs[i].determined;
  return out;
}

Vec6 DofStatusResult::stddev() const {
  Vec6 out;
  for (int i = 0; i < 6; ++i) out[i] = dofs[static_cast<std::size_t>(i)].stddev;
  return out;
}

DofStatusResult decide_dof_status(const DofEvidence& e, const DofStatusConfig& config) {
  DofStatusResult out;
  out.tz_source = e.tz_source;
  for (int i = 0; i < 6; ++i) {
    DofStatus& d = out.dofs[static_cast<std::size_t>(i)];
    d.determined = e.observed[static_cast<std::size_t>(i)] && std::isfinite(e.stddev[i]) && e.stddev[i] > 0.0;
    // tz with no absolute reference is the weakest link: only a tight data estimate counts.
    if (i == 2 && !from_absolute_reference(e.tz_source))
      d.determined = d.determined && e.tz_source == TzSource::kData && e.stddev[2] <= config.max_data_tz_stddev_m;
    d.stddev = d.determined ? e.stddev[i] : std::numeric_limits<double>::infinity();
    const double weak = i < 3 ? config.weak_trans_m : config.weak_rot_deg * kRadPerDeg;
    d.weak = d.determined && d.stddev > weak;
  }
  if (!out.dofs[2].determined) out.advice.push_back(tz_sentence(e));
  std::vector<std::string> missing;
  for (int i : {0, 1, 3, 4, 5})
    if (!out.dofs[static_cast<std::size_t>(i)].determined) missing.push_back(kDofNames[static_cast<std::size_t>(i)]);
  if (!missing.empty())
    out.advice.push_back(fmt::format("{} not determined: drive more turns (figure-8s in both directions) over open, "
                                     "level ground.", fmt::join(missing, ", ")));
  for (int i = 0; i < 6; ++i)
    if (out.dofs[static_cast<std::size_t>(i)].weak) out.advice.push_back(weak_sentence(i, e.stddev[i], e));
  return out;
}

}  // namespace insalign
