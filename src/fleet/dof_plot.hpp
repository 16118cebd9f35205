// A small inline SVG plot of one DOF over time: the points, their +-stddev band, the tolerance
// and the knocks as vertical lines.
#pragma once

#include <string>
#include <vector>

#include "fleet/fleet_summary.hpp"

namespace insalign::fleet {

/// Days since 1970-01-01 of an ISO 8601 date (with an optional time of day); NaN when unreadable.
double iso_days(const std::string& date);

std::string dof_plot_svg(const std::vector<DofPoint>& points, const std::string& title, const std::string& unit,
                         double tolerance, const std::vector<Knock>& knocks);

}  // namespace insalign::fleet
