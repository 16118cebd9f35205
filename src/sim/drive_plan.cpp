#include "sim/drive_plan.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>

namespace insalign::sim {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kGridM = 0.5;  // speed planning resolution along the path

double wrap_pi(double a) { return std::remainder(a, 2.0 * kPi); }

void add_straight(std::vector<PathPoint>& out, Vec2 a, Vec2 b, double step_m, double& carry_m) {
  const Vec2 d = b - a;
  const double len = d.norm();
  if (len <= 0.0) return;
  const double heading = std::atan2(d.y(), d.x());
  double s = carry_m;
  for (; s < len; s += step_m) {
    const Vec2 p = a + d * (s / len);
    out.push_back({p.x(), p.y(), heading, 0.0});
  }
  carry_m = s - len;
}

void add_arc(std::vector<PathPoint>& out, Vec2 centre, double r, double start_rad, double turn_rad, double step_m,
             double& carry_m) {
  const double len = std::abs(turn_rad) * r, sign = turn_rad > 0 ? 1.0 : -1.0;
  double s = carry_m;
  for (; s < len; s += step_m) {
    const double phi = start_rad + sign * s / r;  // angle of the radius vector
    const Vec2 p = centre + r * Vec2(std::cos(phi), std::sin(phi));
    out.push_back({p.x(), p.y(), phi + sign * kPi / 2, sign / r});
  }
  carry_m = s - len;
}

// Legs of a highway: long straights and gentle curves alternating left and right.
std::vector<Vec2> highway_corners(double length_m) {
  std::vector<Vec2> pts{Vec2(0, 0)};
  double heading = 0.0, total = 0.0;
  for (int k = 0; total < length_m; ++k) {
    const double leg = 900.0;
    pts.push_back(pts.back() + leg * Vec2(std::cos(heading), std::sin(heading)));
    total += leg;
    heading += (k % 2 == 0 ? 1.0 : -1.0) * 25.0 * kPi / 180.0;
  }
  pts.push_back(pts.back() + 300.0 * Vec2(std::cos(heading), std::sin(heading)));
  return pts;
}

}  // namespace

std::vector<PathPoint> rounded_polyline(const std::vector<Vec2>& corners, double radius_m, bool closed, double step_m) {
  const std::size_t n = corners.size();
  if (n < 2) throw std::invalid_argument("a path needs at least 2 corners");
  auto dir = [&](std::size_t i) { return (corners[(i + 1) % n] - corners[i]).normalized(); };
  // Per corner: where the straight ends and the next begins (tangent points) and the arc between.
  struct Corner {
    Vec2 in, out, centre;
    double start_rad = 0.0, turn_rad = 0.0;
  };
  std::vector<Corner> c(n);
  for (std::size_t i = 0; i < n; ++i) {
    c[i].in = c[i].out = corners[i];
    if (!closed && (i == 0 || i + 1 == n)) continue;
    const Vec2 d1 = dir((i + n - 1) % n), d2 = dir(i);
    const double turn = wrap_pi(std::atan2(d2.y(), d2.x()) - std::atan2(d1.y(), d1.x()));
    if (std::abs(turn) < 1e-6) continue;
    const double tangent = radius_m * std::tan(std::abs(turn) / 2);
    c[i].in = corners[i] - d1 * tangent;
    c[i].out = corners[i] + d2 * tangent;
    const double sign = turn > 0 ? 1.0 : -1.0;
    const Vec2 normal1(-d1.y() * sign, d1.x() * sign);  // towards the centre
    c[i].centre = c[i].in + normal1 * radius_m;
    const Vec2 from = c[i].in - c[i].centre;
    c[i].start_rad = std::atan2(from.y(), from.x());
    c[i].turn_rad = turn;
  }
  std::vector<PathPoint> out;
  double carry = 0.0;
  const std::size_t legs = closed ? n : n - 1;
  for (std::size_t i = 0; i < legs; ++i) {
    const std::size_t j = (i + 1) % n;
    if (c[i].turn_rad != 0.0 && (closed || i > 0)) add_arc(out, c[i].centre, radius_m, c[i].start_rad, c[i].turn_rad, step_m, carry);
    add_straight(out, c[i].out, c[j].in, step_m, carry);
  }
  return out;
}

DrivePlan ordinary_plan(TrajectoryKind kind, double cruise_kmh, double duration_s, double step_m) {
  DrivePlan p;
  double kmh = 30.0, radius = 10.0;
  std::vector<Vec2> corners;
  switch (kind) {
    case TrajectoryKind::kCityLoop:  // one block, counter-clockwise: every turn a left one
      corners = {{-100, -65}, {100, -65}, {100, 65}, {-100, 65}};
      break;
    case TrajectoryKind::kUrbanGrid:  // a street grid: six left turns, two right ones
      corners = {{-70, -80}, {160, -80}, {160, 0}, {100, 0}, {100, 80}, {0, 80}, {0, 20}, {-70, 20}};
      break;
    case TrajectoryKind::kParkingLot:  // aisles of a lot, turns both ways, slow
      corners = {{0, 0}, {45, 0}, {45, 14}, {8, 14}, {8, 28}, {45, 28}, {45, 42}, {-12, 42}, {-12, 0}};
      kmh = 10.0, radius = 5.0;
      p.stop_probability = 0.3, p.min_stop_s = 2.0, p.max_stop_s = 10.0;
      break;
    case TrajectoryKind::kHighway:
      kmh = 90.0, radius = 1500.0;
      p.closed = false;
      p.stop_probability = 0.0;
      break;
    default: throw std::invalid_argument("not an ordinary drive kind");
  }
  if (cruise_kmh > 0.0) kmh = cruise_kmh;
  p.cruise_mps = kmh / 3.6;
  if (kind == TrajectoryKind::kHighway) corners = highway_corners(p.cruise_mps * std::max(duration_s, 60.0) + 500.0);
  // Centred on the origin (the scene and the yaw0 rotation are about it).
  Vec2 lo = corners.front(), hi = corners.front();
  for (const Vec2& q : corners) lo = lo.cwiseMin(q), hi = hi.cwiseMax(q);
  for (Vec2& q : corners) q -= 0.5 * (lo + hi);
  p.loop = rounded_polyline(corners, radius, p.closed, step_m);
  return p;
}

double SpeedProfile::s_at(double tau, double& v, double& a) const {
  if (t_s.empty()) return v = a = 0.0;
  if (tau <= t_s.front()) return v = v_mps.front(), a = a_mps2.front(), s_m.front();
  if (tau >= t_s.back()) return v = 0.0, a = 0.0, s_m.back();
  const std::size_t i = static_cast<std::size_t>(std::upper_bound(t_s.begin(), t_s.end(), tau) - t_s.begin()) - 1;
  const double f = (tau - t_s[i]) / std::max(t_s[i + 1] - t_s[i], 1e-12);
  v = v_mps[i] + f * (v_mps[i + 1] - v_mps[i]);
  a = a_mps2[i];
  // Constant acceleration within the cell: s advances by the mean speed so far.
  return s_m[i] + (tau - t_s[i]) * 0.5 * (v_mps[i] + v);
}

SpeedProfile plan_speed(const DrivePlan& plan, double duration_s, double step_m, Rng& rng) {
  const double loop_m = static_cast<double>(plan.loop.size()) * step_m;
  const double total_m = plan.closed ? loop_m * std::ceil((plan.cruise_mps * duration_s * 1.1 + 1.0) / loop_m + 1.0) : loop_m;
  const std::size_t n = static_cast<std::size_t>(total_m / kGridM) + 1;
  auto curvature = [&](double s) {
    const std::size_t k = static_cast<std::size_t>(std::fmod(s, loop_m) / step_m);
    return plan.loop[std::min(k, plan.loop.size() - 1)].curvature_per_m;
  };
  std::vector<double> v(n), dwell(n, 0.0);
  for (std::size_t i = 0; i < n; ++i) {
    const double k = std::abs(curvature(i * kGridM));
    v[i] = std::min(plan.cruise_mps, k > 1e-9 ? std::sqrt(plan.lateral_accel_mps2 / k) : plan.cruise_mps);
  }
  // A red light before some corners: where a curve begins, 6 m before it.
  for (std::size_t i = 1; i < n; ++i) {
    const bool corner = std::abs(curvature(i * kGridM)) > 1e-9 && std::abs(curvature((i - 1) * kGridM)) <= 1e-9;
    if (!corner || rng.uniform() >= plan.stop_probability) continue;
    const std::size_t at = i > 12 ? i - 12 : 0;
    v[at] = 0.0;
    dwell[at] = rng.uniform(plan.min_stop_s, plan.max_stop_s);
  }
  v.front() = 0.0, v.back() = 0.0;
  for (std::size_t i = 1; i < n; ++i) v[i] = std::min(v[i], std::sqrt(v[i - 1] * v[i - 1] + 2 * plan.accel_mps2 * kGridM));
  for (std::size_t i = n - 1; i-- > 0;) v[i] = std::min(v[i], std::sqrt(v[i + 1] * v[i + 1] + 2 * plan.decel_mps2 * kGridM));
  SpeedProfile p;
  double t = 0.0;
  for (std::size_t i = 0; i < n && t <= duration_s + 1.0; ++i) {
    const double a = i + 1 < n ? (v[i + 1] * v[i + 1] - v[i] * v[i]) / (2 * kGridM) : 0.0;
    p.t_s.push_back(t), p.s_m.push_back(i * kGridM), p.v_mps.push_back(v[i]), p.a_mps2.push_back(a);
    if (dwell[i] > 0.0) {
      p.a_mps2.back() = 0.0;  // standing: no pitch from the acceleration that follows
      t += dwell[i];
      p.t_s.push_back(t), p.s_m.push_back(i * kGridM), p.v_mps.push_back(0.0), p.a_mps2.push_back(a);
    }
    if (i + 1 < n) t += 2 * kGridM / std::max(v[i] + v[i + 1], 1e-6);
  }
  return p;
}

}  // namespace insalign::sim
