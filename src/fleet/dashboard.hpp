// `fleet report`: the fleet dashboard, OUT/fleet.json and OUT/fleet.html (inline SVG plots).
#pragma once

#include <filesystem>
#include <string>

#include "fleet/fleet_summary.hpp"

namespace insalign::fleet {

/// Links to the rows' own reports are made relative to `out_dir` (where the page is written).
std::string fleet_json(const FleetSummary& summary, const std::filesystem::path& out_dir);
std::string fleet_html(const FleetSummary& summary, const std::filesystem::path& out_dir, const SummaryConfig& config = {});

/// Writes both files atomically into `out_dir`.
void write_dashboard(const FleetSummary& summary, const std::filesystem::path& out_dir, const SummaryConfig& config = {});

}  // namespace insalign::fleet
