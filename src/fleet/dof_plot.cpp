#include "fleet/dof_plot.hpp"

#include <fmt/core.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

namespace insalign::fleet {
namespace {

constexpr double kWidth = 300, kHeight = 150, kLeft = 48, kRight = 8, kTop = 18, kBottom = 22;

struct Axes {
  double x0, x1, y0, y1;
  double x(double days) const { return kLeft + (days - x0) / (x1 - x0) * (kWidth - kLeft - kRight); }
  double y(double v) const { return kTop + (y1 - v) / (y1 - y0) * (kHeight - kTop - kBottom); }
};

Axes fit_axes(const std::vector<DofPoint>& points, double tolerance) {
  Axes a{std::numeric_limits<double>::max(), std::numeric_limits<double>::lowest(), -tolerance, tolerance};
  for (const DofPoint& p : points) {
    const double d = iso_days(p.date), s = p.stddev.value_or(0.0);
    a.x0 = std::min(a.x0, d);
    a.x1 = std::max(a.x1, d);
    a.y0 = std::min(a.y0, p.change - s);
    a.y1 = std::max(a.y1, p.change + s);
  }
  if (!(a.x1 > a.x0)) a.x0 -= 1.0, a.x1 += 1.0;
  const double pad = 0.08 * (a.y1 - a.y0);
  a.y0 -= pad;
  a.y1 += pad;
  return a;
}

}  // namespace

double iso_days(const std::string& date) {
  if (date.size() < 10) return std::nan("");
  try {
    const int y = std::stoi(date.substr(0, 4)), m = std::stoi(date.substr(5, 2)), d = std::stoi(date.substr(8, 2));
    const std::chrono::sys_days day{std::chrono::year(y) / m / d};
    double days = static_cast<double>(day.time_since_epoch().count());
    if (date.size() >= 16 && date[10] == 'T') days += (std::stoi(date.substr(11, 2)) * 60 + std::stoi(date.substr(14, 2))) / 1440.0;
    return days;
  } catch (...) {
    return std::nan("");
  }
}

std::string dof_plot_svg(const std::vector<DofPoint>& points, const std::string& title, const std::string& unit,
                         double tolerance, const std::vector<Knock>& knocks) {
  const Axes a = fit_axes(points, tolerance);
  std::string s = fmt::format(R"(<svg xmlns="http://www.w3.org/2000/svg" width="{}" height="{}" class="dof">)", kWidth, kHeight);
  s += fmt::format(R"(<text x="{}" y="12" class="t">{} ({})</text>)", kLeft, title, unit);
  s += fmt::format(R"(<rect x="{}" y="{:.1f}" width="{}" height="{:.1f}" class="tol"/>)", kLeft, a.y(tolerance),
                   kWidth - kLeft - kRight, a.y(-tolerance) - a.y(tolerance));
  s += fmt::format(R"(<line x1="{}" x2="{}" y1="{:.1f}" y2="{:.1f}" class="zero"/>)", kLeft, kWidth - kRight, a.y(0), a.y(0));
  for (double v : {a.y0, a.y1})
    s += fmt::format(R"(<text x="{}" y="{:.1f}" class="l" text-anchor="end">{:.3g}</text>)", kLeft - 3, a.y(v) + 4, v);
  for (const Knock& k : knocks) {
    const double x = a.x(iso_days(k.date));
    s += fmt::format(R"(<line x1="{0:.1f}" x2="{0:.1f}" y1="{1}" y2="{2}" class="knock"><title>knock {3}</title></line>)", x, kTop,
                     kHeight - kBottom, k.date);
  }
  std::string band_top, band_bottom, line;
  for (const DofPoint& p : points) {
    const double x = a.x(iso_days(p.date)), sd = p.stddev.value_or(0.0);
    band_top += fmt::format("{:.1f},{:.1f} ", x, a.y(p.change + sd));
    band_bottom = fmt::format("{:.1f},{:.1f} ", x, a.y(p.change - sd)) + band_bottom;
    line += fmt::format("{:.1f},{:.1f} ", x, a.y(p.change));
  }
  if (!points.empty()) {
    s += R"(<polygon class="band" points=")" + band_top + band_bottom + R"("/>)";
    s += R"(<polyline class="v" points=")" + line + R"("/>)";
  }
  for (const DofPoint& p : points)
    s += fmt::format(R"(<circle cx="{:.1f}" cy="{:.1f}" r="3" class="{}"><title>{} {}: {:.4g} +- {:.2g} {}</title></circle>)",
                     a.x(iso_days(p.date)), a.y(p.change), p.verdict == "drifted" ? "bad" : p.kind, p.run_id, p.verdict, p.change,
                     p.stddev.value_or(0.0), unit);
  if (!points.empty()) {
    s += fmt::format(R"(<text x="{}" y="{}" class="l">{}</text>)", kLeft, kHeight - 6, points.front().date.substr(0, 10));
    s += fmt::format(R"(<text x="{}" y="{}" class="l" text-anchor="end">{}</text>)", kWidth - kRight, kHeight - 6,
                     points.back().date.substr(0, 10));
  }
  return s + "</svg>";
}

}  // namespace insalign::fleet
