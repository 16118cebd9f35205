#include "sim/ins_error.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>

#include "sim/random.hpp"

namespace insalign::sim {
namespace {

constexpr double kPi = std::numbers::pi;
// RTK-fixed GNSS/INS position error is bounded, not a random walk: a first-order Gauss-Markov
// process per axis, stationary from the first sample (NovAtel RTK: ~1 cm + 1 ppm horizontal RMS,
// vertical about 1.5 times worse), decorrelating over tens of seconds as satellites and multipath
// change. Its mean over a drive is what no LiDAR data can reveal: it sets the floor of the
// fiducial z accuracy (README, stage 3).
constexpr double kPosDriftSigmaHorizontalM = 0.01;
constexpr double kPosDriftSigmaVerticalM = 0.015;
constexpr double kPosDriftCorrelationS = 30.0;
constexpr double kWalkKnotSpacingS = 0.1;
// Events keep this far from the drive's ends (or a tenth of a short drive) and from each other.
constexpr double kEventEndMarginS = 15.0;
constexpr double kEventGapS = 5.0;

// Raised-cosine bump: 0 at both ends, 1 in the middle, smooth.
double bump(double u) {
  const double s = std::sin(kPi * u);
  return s * s;
}

double progress(const InsEvent& e, double t_s) { return (t_s - e.t_begin_s) / (e.t_end_s - e.t_begin_s); }
bool active(const InsEvent& e, double t_s) { return t_s >= e.t_begin_s && t_s < e.t_end_s; }

// A random direction, mostly horizontal: |vertical| <= vertical_share before normalising.
Vec3 direction(Rng& rng, double vertical_share) {
  const double az = rng.uniform(-kPi, kPi);
  const double vz = rng.uniform(-vertical_share, vertical_share);
  return Vec3(std::cos(az), std::sin(az), vz).normalized();
}

double random_sign(Rng& rng) { return rng.uniform() < 0.5 ? -1.0 : 1.0; }

InsEvent draw_event(const InsErrorConfig& c, InsEventKind kind, Rng& rng) {
  InsEvent e;
  e.kind = kind;
  if (kind == InsEventKind::kFloatEpisode) {
    e.t_end_s = c.float_duration_s;
    e.error_m = c.float_peak_m * direction(rng, 0.5);
  } else if (kind == InsEventKind::kWrongFix) {
    e.t_end_s = c.wrong_fix_duration_s;
    e.error_m = c.wrong_fix_jump_m * direction(rng, 0.5);
  } else {
    e.t_end_s = c.outage_duration_s;
    e.error_m = c.outage_error_m * direction(rng, 0.3);
    const double roll = random_sign(rng), pitch = random_sign(rng), yaw = random_sign(rng);
    e.rpy_error_rad = kRadPerDeg * Vec3(roll * c.outage_tilt_deg, pitch * c.outage_tilt_deg, yaw * c.outage_heading_deg);
  }
  return e;  // t_begin_s = 0, t_end_s = duration: shifted into place by the caller
}

}  // namespace

const char* ins_error_model_name(InsErrorModel model) {
  return model == InsErrorModel::kDrift ? "drift" : "rtk-fixed";
}

bool parse_ins_error_model(const std::string& name, InsErrorModel& out) {
  if (name == "rtk-fixed") {
    out = InsErrorModel::kRtkFixed;
  } else if (name == "drift") {
    out = InsErrorModel::kDrift;
  } else {
    return false;
  }
  return true;
}

const char* ins_event_name(InsEventKind kind) {
  switch (kind) {
    case InsEventKind::kFloatEpisode: return "float_episode";
    case InsEventKind::kWrongFix: return "wrong_fix";
    case InsEventKind::kOutage: return "outage";
  }
  return "?";
}

Vec3 InsDrift::at(double t_s) const {
  if (knots_m.empty()) return Vec3::Zero();
  const double f = (t_s - t0_s) / knot_spacing_s;
  if (f <= 0.0) return knots_m.front();
  const std::size_t i = static_cast<std::size_t>(f);
  if (i + 1 >= knots_m.size()) return knots_m.back();
  const double w = f - static_cast<double>(i);
  return (1.0 - w) * knots_m[i] + w * knots_m[i + 1];
}

double InsWalk::heading_at(double t_s) const {
  if (heading_rad.empty()) return 0.0;
  const double f = (t_s - position.t0_s) / position.knot_spacing_s;
  if (f <= 0.0) return heading_rad.front();
  const std::size_t i = static_cast<std::size_t>(f);
  if (i + 1 >= heading_rad.size()) return heading_rad.back();
  const double w = f - static_cast<double>(i);
  return (1.0 - w) * heading_rad[i] + w * heading_rad[i + 1];
}

InsDrift make_rtk_fixed_drift(double noise_scale, double t0_s, double t1_s, std::uint64_t seed) {
  Rng rng(seed);
  InsDrift drift;
  drift.t0_s = t0_s;
  drift.knot_spacing_s = 1.0;
  const Vec3 sigma = noise_scale * Vec3(kPosDriftSigmaHorizontalM, kPosDriftSigmaHorizontalM, kPosDriftSigmaVerticalM);
  const double a = std::exp(-drift.knot_spacing_s / kPosDriftCorrelationS);
  const double innovation = std::sqrt(1.0 - a * a);
  auto draw = [&]() {  // one statement per axis: argument evaluation order is unspecified
    Vec3 v;
    for (int axis = 0; axis < 3; ++axis) v[axis] = rng.normal(sigma[axis]);
    return v;
  };
  Vec3 error = draw();  // stationary from the start: the INS is no more exact at t0 than later
  for (double t = t0_s; t <= t1_s + 1.0; t += drift.knot_spacing_s) {
    drift.knots_m.push_back(error);
    error = a * error + innovation * draw();
  }
  return drift;
}

InsWalk make_walk(const InsErrorConfig& c, double t0_s, double t1_s, std::uint64_t seed) {
  Rng rng(seed);
  InsWalk walk;
  walk.position.t0_s = t0_s;
  walk.position.knot_spacing_s = kWalkKnotSpacingS;
  const double root_dt = std::sqrt(kWalkKnotSpacingS);
  const Vec3 step_sigma = root_dt * Vec3(c.drift_horizontal_m_per_sqrt_s, c.drift_horizontal_m_per_sqrt_s,
                                         c.drift_vertical_m_per_sqrt_s);
  const double heading_sigma = root_dt * c.drift_heading_deg_per_sqrt_s * kRadPerDeg;
  Vec3 p = Vec3::Zero();
  double heading = 0.0;
  const std::size_t n = static_cast<std::size_t>(std::ceil((t1_s - t0_s) / kWalkKnotSpacingS)) + 2;
  for (std::size_t k = 0; k < n; ++k) {
    walk.position.knots_m.push_back(p);
    walk.heading_rad.push_back(heading);
    for (int axis = 0; axis < 3; ++axis) p[axis] += rng.normal(step_sigma[axis]);
    heading += rng.normal(heading_sigma);
  }
  return walk;
}

std::vector<InsEvent> place_ins_events(const InsErrorConfig& c, double t_begin_s, double t_end_s, std::uint64_t seed) {
  Rng rng(seed);
  std::vector<InsEvent> events;
  const double margin_s = std::min(kEventEndMarginS, 0.1 * (t_end_s - t_begin_s));
  const std::pair<InsEventKind, int> wanted[] = {{InsEventKind::kFloatEpisode, c.float_episodes},
                                                 {InsEventKind::kWrongFix, c.wrong_fixes},
                                                 {InsEventKind::kOutage, c.outages}};
  for (const auto& [kind, count] : wanted) {
    for (int i = 0; i < count; ++i) {
      InsEvent e = draw_event(c, kind, rng);
      const double duration_s = e.t_end_s;
      const double lo = t_begin_s + margin_s, hi = t_end_s - margin_s - duration_s;
      bool placed = false;
      for (int attempt = 0; attempt < 1000 && hi > lo && !placed; ++attempt) {
        e.t_begin_s = rng.uniform(lo, hi);
        e.t_end_s = e.t_begin_s + duration_s;
        placed = std::none_of(events.begin(), events.end(), [&](const InsEvent& o) {
          return e.t_begin_s < o.t_end_s + kEventGapS && o.t_begin_s < e.t_end_s + kEventGapS;
        });
      }
      if (!placed)
        throw std::invalid_argument("cannot fit " + std::to_string(c.float_episodes + c.wrong_fixes + c.outages) +
                                    " INS events into a " + std::to_string(static_cast<int>(t_end_s - t_begin_s)) +
                                    " s drive (they keep " + std::to_string(static_cast<int>(margin_s)) +
                                    " s from its ends and 5 s apart): use a longer drive or fewer events");
      events.push_back(e);
    }
  }
  std::sort(events.begin(), events.end(), [](const InsEvent& a, const InsEvent& b) { return a.t_begin_s < b.t_begin_s; });
  return events;
}

Vec3 event_position_error(const InsEvent& e, double t_s) {
  if (!active(e, t_s)) return Vec3::Zero();
  const double u = progress(e, t_s);
  switch (e.kind) {
    case InsEventKind::kFloatEpisode: return bump(u) * e.error_m;
    case InsEventKind::kWrongFix: return e.error_m;
    case InsEventKind::kOutage: return (u * u) * e.error_m;
  }
  return Vec3::Zero();
}

Vec3 event_rpy_error_rad(const InsEvent& e, double t_s) {
  if (e.kind != InsEventKind::kOutage || !active(e, t_s)) return Vec3::Zero();
  return progress(e, t_s) * e.rpy_error_rad;
}

InsQuality event_quality(const std::vector<InsEvent>& events, double t_s, double normal_h_m, double normal_v_m) {
  InsQuality q;
  q.t_s = t_s;
  q.solution = GnssSolution::kRtkFixed;
  q.horizontal_stddev_m = normal_h_m;
  q.vertical_stddev_m = normal_v_m;
  for (const InsEvent& e : events) {
    if (!active(e, t_s)) continue;
    const double u = progress(e, t_s);
    const double peak_m = e.error_m.norm();
    if (e.kind == InsEventKind::kFloatEpisode) {
      // A third of the peak at the edges, the peak in the middle: 0.1 -> 0.3 m at 0.3 m.
      q.solution = GnssSolution::kRtkFloat;
      q.horizontal_stddev_m = std::max(normal_h_m, peak_m * (1.0 / 3.0 + 2.0 / 3.0 * bump(u)));
      q.vertical_stddev_m = std::max(normal_v_m, 1.5 * q.horizontal_stddev_m);
    } else if (e.kind == InsEventKind::kOutage) {
      // The coasting filter's covariance grows like the error (quadratically), a little pessimistic.
      q.solution = GnssSolution::kInsOnly;
      q.horizontal_stddev_m = normal_h_m + 1.2 * peak_m * u * u;
      q.vertical_stddev_m = normal_v_m + 1.2 * peak_m * u * u;
    }
    // A wrong fix looks like any other fix.
  }
  return q;
}

void validate_ins_error(const InsErrorConfig& c) {
  auto fail = [](const std::string& what) { throw std::invalid_argument(what); };
  auto rate_ok = [](double v) { return v >= 0.0 && v <= 1.0; };
  if (!rate_ok(c.drift_horizontal_m_per_sqrt_s) || !rate_ok(c.drift_vertical_m_per_sqrt_s))
    fail("INS drift rates must be in [0, 1] m/sqrt(s)");
  if (!(c.drift_heading_deg_per_sqrt_s >= 0.0 && c.drift_heading_deg_per_sqrt_s <= 1.0))
    fail("INS heading drift must be in [0, 1] deg/sqrt(s)");
  if (c.float_episodes < 0 || c.wrong_fixes < 0 || c.outages < 0 || c.float_episodes + c.wrong_fixes + c.outages > 100)
    fail("INS event counts must be >= 0 and at most 100 in all");
  for (double d : {c.float_duration_s, c.wrong_fix_duration_s, c.outage_duration_s})
    if (!(d >= 0.5 && d <= 600.0)) fail("INS event durations must be in [0.5, 600] s");
  for (double m : {c.float_peak_m, c.wrong_fix_jump_m, c.outage_error_m})
    if (!(m >= 0.0 && m <= 100.0)) fail("INS event errors must be in [0, 100] m");
  if (!(c.outage_tilt_deg >= 0.0 && c.outage_tilt_deg <= 10.0) || !(c.outage_heading_deg >= 0.0 && c.outage_heading_deg <= 10.0))
    fail("INS outage attitude errors must be in [0, 10] deg");
}

}  // namespace insalign::sim
