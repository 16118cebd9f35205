#include "core/check_history.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace insalign {
namespace {

// Information-weighted mean of per-drive values (inverse-variance weights); +inf stddev when no
// drive determines the DOF.
struct Combined {
  double sum_w = 0.0, sum_wx = 0.0;
  void add(double x, double sd) {
    if (!std::isfinite(x) || !std::isfinite(sd) || sd <= 0.0) return;
    sum_w += 1.0 / (sd * sd);
    sum_wx += x / (sd * sd);
  }
  bool any() const { return sum_w > 0.0; }
  double mean() const { return any() ? sum_wx / sum_w : 0.0; }
  double stddev() const { return any() ? 1.0 / std::sqrt(sum_w) : std::numeric_limits<double>::infinity(); }
};

// Each record's measurement as a correction of the extrinsic installed now: records checked
// against another installed extrinsic (before a recalibration) stay comparable.
Vec7 measured_correction(const CheckRecord& r, const Iso3& T_installed, double offset_installed_s) {
  return extrinsic_correction(T_installed, offset_installed_s, r.T_ins_lidar_corrected, r.time_offset_corrected_s);
}

// Why record x is a step away from the combination so far, or "" when it is not.
std::string step_reason(const Vec7& x, const std::array<double, 7>& sd, const std::array<Combined, 7>& so_far,
                        const CheckConfig& check, const HistoryConfig& config) {
  std::vector<std::string> moved;
  for (int i = 0; i < 7; ++i) {
    if (!so_far[i].any() || !std::isfinite(sd[i])) continue;
    const double diff = x(i) - so_far[i].mean();
    const double sigma = std::hypot(sd[i], so_far[i].stddev());
    if (std::abs(diff) > config.step_sigmas * sigma && std::abs(diff) > dof_tolerance(i, check))
      moved.push_back(fmt::format("{} {:+.4g} {} ({:.1f} stddev)", kCheckDofNames[i], diff, kCheckDofUnits[i],
                                  std::abs(diff) / sigma));
  }
  return moved.empty() ? "" : fmt::format("{}", fmt::join(moved, ", "));
}

}  // namespace

HistoryFindings combine_history(std::vector<CheckRecord> records, const Iso3& T_installed, double offset_installed_s,
                                const CheckConfig& check, const HistoryConfig& config) {
  if (records.empty()) throw std::invalid_argument("combine_history: no records");
  std::sort(records.begin(), records.end(),
            [](const CheckRecord& a, const CheckRecord& b) { return a.drive_end < b.drive_end; });
  HistoryFindings out;
  std::array<Combined, 7> segment{};
  std::size_t first = 0;
  for (std::size_t k = 0; k < records.size(); ++k) {
    const Vec7 x = measured_correction(records[k], T_installed, offset_installed_s);
    const std::string why = k > first ? step_reason(x, records[k].stddev, segment, check, config) : "";
    if (!why.empty()) {
      out.steps.push_back({records[k].drive_end, records[k - 1].drive_end, why});
      segment = {};
      first = k;
    }
    for (int i = 0; i < 7; ++i) segment[i].add(x(i), records[k].stddev[i]);
  }
  out.drives = static_cast<int>(records.size() - first);
  out.since = records[first].drive_end;
  for (int i = 0; i < 7; ++i) out.dofs[i] = judge_dof(i, segment[i].mean(), segment[i].stddev(), check);
  const std::array<bool, 7> unchecked = unchecked_dofs(check);
  out.verdict = overall_verdict(out.dofs, unchecked);
  out.message = verdict_message(out.dofs, out.verdict, unchecked) +
                fmt::format(" (on {} drive{} since {})", out.drives, out.drives == 1 ? "" : "s", out.since);
  if (!out.steps.empty())
    out.message += fmt::format("; step change between {} and {}: {}", out.steps.back().before, out.steps.back().date,
                               out.steps.back().why);
  return out;
}

}  // namespace insalign
