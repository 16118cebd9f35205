#include "fleet/dashboard.hpp"

#include <fmt/core.h>

#include <nlohmann/json.hpp>

#include "fleet/dof_plot.hpp"
#include "fleet/status.hpp"
#include "files/atomic_file.hpp"

namespace insalign::fleet {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

constexpr std::array<const char*, 7> kUnits{"m", "m", "m", "deg", "deg", "deg", "s"};

std::string link(const std::string& report, const fs::path& out_dir) {
  if (report.empty()) return "";
  std::error_code ec;
  const fs::path rel = fs::relative(report, fs::absolute(out_dir), ec);
  return ec || rel.empty() ? report : rel.string();
}

std::string esc(const std::string& s) {
  std::string out;
  for (char c : s) {
    switch (c) {
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '&': out += "&amp;"; break;
      case '"': out += "&quot;"; break;
      default: out += c;
    }
  }
  return out;
}

json run_json(const RunRecord& r, const fs::path& out_dir) {
  return {{"id", r.id},         {"car", r.car},           {"date", r.date},       {"kind", r.kind},
          {"exit_code", r.exit_code}, {"verdict", r.verdict}, {"error", r.error}, {"attempts", r.attempts},
          {"host", r.host},     {"started", r.started},   {"ended", r.ended},     {"report", link(r.report, out_dir)}};
}

json car_json(const CarSummary& c, const fs::path& out_dir) {
  json knocks = json::array();
  for (const Knock& k : c.knocks) knocks.push_back({{"date", k.date}, {"after", k.after}, {"run", k.run_id}, {"what", k.what}});
  json series = json::object();
  for (const auto& [lidar, dofs] : c.series) {
    for (std::size_t i = 0; i < 7; ++i) {
      json points = json::array();
      for (const DofPoint& p : dofs[i]) {
        points.push_back({{"date", p.date}, {"run", p.run_id}, {"kind", p.kind}, {"change", p.change},
                          {"stddev", p.stddev ? json(*p.stddev) : json(nullptr)}, {"verdict", p.verdict}});
      }
      series[lidar][kFleetDofs[i]] = points;
    }
  }
  return {{"car", c.car}, {"state", c.state}, {"needs_recalibration", c.needs_recalibration}, {"why", c.why},
          {"latest", {{"date", c.latest_date}, {"run", c.latest_run}, {"verdict", c.latest_verdict}, {"report", link(c.latest_report, out_dir)}}},
          {"runs", c.runs}, {"failed", c.failed}, {"knocks", knocks}, {"series", series}};
}

const char* kStyle = R"(<style>
body{font-family:sans-serif;margin:1.5em;color:#222} table{border-collapse:collapse;margin:.5em 0}
td,th{border:1px solid #ccc;padding:3px 8px;text-align:left;font-size:14px} th{background:#f3f3f3}
.recalibrate,.changed,.failed{background:#fdd} .ok,.calibrated{background:#dfd} .inconclusive,.not-determined{background:#ffd}
svg.dof{border:1px solid #ddd;margin:2px} svg .t{font-size:11px;font-weight:bold} svg .l{font-size:9px;fill:#555}
svg .tol{fill:#e8f4e8} svg .zero{stroke:#999;stroke-width:.5} svg .band{fill:#9bd;opacity:.45}
svg .v{fill:none;stroke:#246;stroke-width:1} svg circle.check{fill:#246} svg circle.calibrate{fill:#fff;stroke:#246}
svg circle.bad{fill:#c22} svg .knock{stroke:#c22;stroke-width:1.5;stroke-dasharray:3,2}
</style>)";

std::string cars_table(const FleetSummary& s, const fs::path& out_dir) {
  std::string h = "<h2>Cars</h2><table><tr><th>car</th><th>state</th><th>latest</th><th>verdict</th><th>why</th><th>knocks</th>"
                  "<th>runs</th><th>failed</th></tr>";
  for (const CarSummary& c : s.cars) {
    std::string knocks;
    for (const Knock& k : c.knocks) knocks += esc(k.date) + ": " + esc(k.what) + "<br>";
    const std::string rel = link(c.latest_report, out_dir);
    h += fmt::format(R"(<tr class="{0}"><td><a href="#car-{1}">{1}</a></td><td>{0}{2}</td><td>{3}</td><td>{4}</td><td>{5}</td><td>{6}</td><td>{7}</td><td>{8}</td></tr>)",
                     esc(c.state), esc(c.car), c.needs_recalibration ? " (needs recalibration)" : "",
                     rel.empty() ? esc(c.latest_date) : "<a href=\"" + esc(rel) + "\">" + esc(c.latest_date) + "</a>",
                     esc(c.latest_verdict), esc(c.why), knocks, c.runs, c.failed);
  }
  return h + "</table>";
}

std::string failed_table(const FleetSummary& s) {
  std::string h = fmt::format("<h2>Failed rows ({})</h2>", s.failed.size());
  if (s.failed.empty()) return h + "<p>none</p>";
  h += "<table><tr><th>row</th><th>exit code</th><th>attempts</th><th>host</th><th>ended</th><th>error</th></tr>";
  for (const RunRecord& r : s.failed)
    h += fmt::format("<tr class=\"failed\"><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>", esc(r.id), r.exit_code,
                     r.attempts, esc(r.host), esc(r.ended), esc(r.error));
  return h + "</table>";
}

std::string car_section(const CarSummary& c, const FleetSummary& s, const fs::path& out_dir, const SummaryConfig& cfg) {
  std::string h = fmt::format(R"(<h2 id="car-{0}">{0}: {1}</h2>)", esc(c.car), esc(c.state));
  if (!c.why.empty()) h += "<p>" + esc(c.why) + "</p>";
  for (const auto& [lidar, dofs] : c.series) {
    h += "<p>" + esc(lidar) + ": checks plot their correction, calibrations their change since the car's first calibration; "
         "band +-1 stddev, green the tolerance, red dashes the knocks.</p><div>";
    const double tol[7] = {cfg.tolerance_m, cfg.tolerance_m, cfg.tolerance_m, cfg.tolerance_deg, cfg.tolerance_deg, cfg.tolerance_deg,
                           cfg.tolerance_time_s};
    for (std::size_t i = 0; i < 7; ++i) h += dof_plot_svg(dofs[i], kFleetDofs[i], kUnits[i], tol[i], c.knocks);
    h += "</div>";
  }
  h += "<table><tr><th>row</th><th>kind</th><th>verdict</th><th>exit code</th><th>attempts</th><th>report</th></tr>";
  for (const RunRecord& r : s.runs) {
    if (r.car != c.car) continue;
    const std::string rel = link(r.report, out_dir);
    h += fmt::format(R"(<tr class="{}"><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>)", esc(r.verdict), esc(r.id),
                     esc(r.kind), esc(r.verdict), r.exit_code, r.attempts,
                     rel.empty() ? esc(r.error) : "<a href=\"" + esc(rel) + "\">" + esc(fs::path(rel).filename().string()) + "</a>");
  }
  return h + "</table>";
}

}  // namespace

std::string fleet_json(const FleetSummary& s, const fs::path& out_dir) {
  json cars = json::array(), failed = json::array(), runs = json::array();
  for (const CarSummary& c : s.cars) cars.push_back(car_json(c, out_dir));
  for (const RunRecord& r : s.failed) failed.push_back(run_json(r, out_dir));
  for (const RunRecord& r : s.runs) runs.push_back(run_json(r, out_dir));
  int needing = 0;
  for (const CarSummary& c : s.cars) needing += c.needs_recalibration;
  return json({{"generated", utc_now()}, {"cars_needing_recalibration", needing}, {"cars", cars}, {"failed", failed}, {"runs", runs}})
             .dump(2) + "\n";
}

std::string fleet_html(const FleetSummary& s, const fs::path& out_dir, const SummaryConfig& cfg) {
  int needing = 0;
  for (const CarSummary& c : s.cars) needing += c.needs_recalibration;
  std::string h = "<!DOCTYPE html><html><head><meta charset=\"utf-8\"><title>insalign fleet</title>" + std::string(kStyle) + "</head><body>";
  h += fmt::format("<h1>insalign fleet</h1><p>{} cars, {} rows, {} failed; <b>{} need recalibration</b>. Generated {}.</p>", s.cars.size(),
                   s.runs.size(), s.failed.size(), needing, utc_now());
  h += cars_table(s, out_dir) + failed_table(s);
  for (const CarSummary& c : s.cars) h += car_section(c, s, out_dir, cfg);
  return h + "</body></html>\n";
}

void write_dashboard(const FleetSummary& s, const fs::path& out_dir, const SummaryConfig& cfg) {
  io::ensure_writable_dir(out_dir);
  io::write_file_atomic(out_dir / "fleet.json", fleet_json(s, out_dir));
  io::write_file_atomic(out_dir / "fleet.html", fleet_html(s, out_dir, cfg));
}

}  // namespace insalign::fleet
