// Ray casting of one LiDAR frame: every column (spinning) or firing (rosette) at its own instant,
// from the sensor's true pose then, into the static scene and the movers placed where they are
// then; in a rig the ego body blocks what it hides.
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <numbers>

#include "sim/random.hpp"
#include "sim/rig.hpp"
#include "sim/scene.hpp"
#include "sim/simulate.hpp"
#include "sim/traffic.hpp"

namespace insalign::sim {
namespace {

constexpr double kPi = std::numbers::pi;

// One slot per ray, filled by any thread, compacted afterwards in firing order: deterministic
// whatever the threads do.
struct Slots {
  std::vector<Vec3f> p;
  std::vector<float> intensity;
  std::vector<std::uint8_t> ok, mover;
  explicit Slots(std::size_t n) : p(n), intensity(n), ok(n, 0), mover(n, 0) {}
};

// The movers a column's fan of rays can meet: all rays of a spinning column lie in the half
// plane spanned by the column's horizontal direction u and the sensor's z axis w.
void cull_for_column(const std::vector<PlacedMover>& placed, const Vec3& origin, const Vec3& u, const Vec3& w,
                     std::vector<PlacedMover>& out) {
  out.clear();
  const Vec3 n = u.cross(w);
  for (const PlacedMover& p : placed) {
    const Vec3 rel = p.center_m - origin;
    if (std::abs(n.dot(rel)) <= p.radius_m && u.dot(rel) >= -p.radius_m) out.push_back(p);
  }
}

// What one firing instant sees besides the static scene: the movers near its rays and, in a rig,
// the ego body (a box in the vehicle frame, with the world-to-vehicle transform of that instant).
struct Instant {
  std::vector<PlacedMover> movers;
  const Box* body = nullptr;
  Iso3 T_vehicle_world = Iso3::Identity();
};

// Range noise, dropout and intensity of one ray; false if it returns nothing. The noise is keyed
// by the ray, so a ray gives the same return whatever thread casts it.
bool measure(const World& world, const Vec3& origin, const Vec3& d_lidar, const Vec3& d_world, std::uint64_t key,
             const Instant& instant, Vec3f& p_out, float& intensity_out, bool& mover_out) {
  const SimConfig& c = world.config;
  if (c.dropout_prob > 0.0 && unit_from_bits(splitmix64(key ^ 1)) < c.dropout_prob) return false;
  const double max_cast_m = c.max_range_m + 5.0 * c.range_noise_m + 0.1;
  auto hit = world.scene->cast(origin, d_world, max_cast_m);
  mover_out = false;
  if (!instant.movers.empty()) {
    if (auto m = cast_movers(instant.movers, origin, d_world, hit ? hit->range_m : max_cast_m)) {
      hit = m;
      mover_out = true;
    }
  }
  if (!hit) return false;
  if (instant.body) {
    double t = 0.0;
    Vec3 n;
    if (hit_box(*instant.body, instant.T_vehicle_world * origin, instant.T_vehicle_world.linear() * d_world, hit->range_m, t, n))
      return false;  // the car's own body is in the way
  }
  const double range = hit->range_m + c.range_noise_m * normal_from_bits(splitmix64(key ^ 2), splitmix64(key ^ 3));
  if (range <= 0.3 || range > c.max_range_m) return false;
  const double cos_inc = std::abs(hit->normal.dot(d_world));
  const double intensity = 255.0 * hit->reflectivity * (0.25 + 0.75 * cos_inc) +
                           2.0 * normal_from_bits(splitmix64(key ^ 4), splitmix64(key ^ 5));
  p_out = (d_lidar * range).cast<float>();
  intensity_out = static_cast<float>(std::clamp(intensity, 0.0, 255.0));
  return true;
}

// Compacts the slots (ray s fired at time_of(s)) into a sweep whose frame time is the latest
// point time.
template <class TimeOf, class RingOf>
Sweep compact(const Slots& slots, double t_end_nominal, TimeOf time_of, RingOf ring_of,
              std::vector<std::uint8_t>* hit_mover) {
  std::size_t n = 0, last = slots.ok.size();
  for (std::size_t s = 0; s < slots.ok.size(); ++s) {
    if (!slots.ok[s]) continue;
    ++n;
    last = s;
  }
  Sweep sweep;
  sweep.t_end_s = last < slots.ok.size() ? time_of(last) : t_end_nominal;
  sweep.name = frame_name(sweep.t_end_s);
  sweep.p_lidar.reserve(n);
  sweep.dt_s.reserve(n);
  sweep.intensity.reserve(n);
  sweep.ring.reserve(n);
  if (hit_mover) {
    hit_mover->clear();
    hit_mover->reserve(n);
  }
  for (std::size_t s = 0; s < slots.ok.size(); ++s) {
    if (!slots.ok[s]) continue;
    sweep.p_lidar.push_back(slots.p[s]);
    sweep.dt_s.push_back(static_cast<float>(time_of(s) - sweep.t_end_s));
    sweep.intensity.push_back(slots.intensity[s]);
    sweep.ring.push_back(static_cast<std::uint16_t>(ring_of(s)));
    if (hit_mover) hit_mover->push_back(slots.mover[s]);
  }
  return sweep;
}

// The ego body of a rig (none for a single LiDAR, whose output must not change).
struct Body {
  Box box;
  Iso3 T_ins_vehicle = Iso3::Identity();
  bool blocks = false;
  explicit Body(const World& w)
      : box(EgoBody::box(w.ins_height_m)), T_ins_vehicle(w.T_vehicle_ins.inverse()), blocks(!w.config.rig.empty()) {}
  void at(const Iso3& T_world_ins, Instant& instant) const {
    if (!blocks) return;
    instant.body = &box;
    instant.T_vehicle_world = (T_world_ins * T_ins_vehicle).inverse();
  }
};

Sweep render_spinning(const World& world, const SimLidar& lidar, std::size_t k, std::vector<std::uint8_t>* hit_mover) {
  const SimConfig& c = world.config;
  const std::size_t n_cols = std::max<std::size_t>(1, static_cast<std::size_t>(std::llround(360.0 / c.azimuth_step_deg)));
  const std::size_t n_beams = lidar.model.elevation_deg.size();
  const double period_s = 1.0 / lidar.frame_rate_hz;
  const double col_dt_s = period_s / static_cast<double>(n_cols);
  const double step_rad = 2 * kPi / static_cast<double>(n_cols);
  const double t_end_nominal = lidar.frame_times_s.at(k);
  std::vector<double> cos_el(n_beams), sin_el(n_beams);
  for (std::size_t b = 0; b < n_beams; ++b) {
    cos_el[b] = std::cos(lidar.model.elevation_deg[b] * kRadPerDeg);
    sin_el[b] = std::sin(lidar.model.elevation_deg[b] * kRadPerDeg);
  }
  auto column_time = [&](std::size_t j) { return t_end_nominal - static_cast<double>(n_cols - 1 - j) * col_dt_s; };
  const bool movers = world.traffic && !world.traffic->movers.empty();
  Slots slots(n_cols * n_beams);

  const Body body(world);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n_cols, 32), [&](const tbb::blocked_range<std::size_t>& r) {
    std::vector<PlacedMover> placed;
    Instant instant;
    for (std::size_t j = r.begin(); j < r.end(); ++j) {
      const double t_ins = column_time(j) + lidar.time_offset_s;  // INS clock = LiDAR clock + offset
      // The sensor's TRUE pose at this column's instant.
      const Iso3 T_world_ins = world.poses_true.T_world_ins(t_ins);
      const Iso3 T_world_lidar = T_world_ins * lidar.T_ins_lidar_true;
      const Mat3 R = T_world_lidar.linear();
      const Vec3 origin = T_world_lidar.translation();
      // Clockwise spin seen from above.
      const double az = lidar.start_azimuth_rad - static_cast<double>(j) * step_rad;
      const double ca = std::cos(az), sa = std::sin(az);
      if (movers) {
        world.traffic->place(t_ins, world.scene->ground, placed);
        cull_for_column(placed, origin, R * Vec3(ca, sa, 0.0), R.col(2), instant.movers);
      }
      body.at(T_world_ins, instant);
      for (std::size_t b = 0; b < n_beams; ++b) {
        const std::uint64_t key = hash_counters(lidar.noise_seed, k, j, b);
        const Vec3 d_lidar(cos_el[b] * ca, cos_el[b] * sa, sin_el[b]);
        const std::size_t s = j * n_beams + b;
        bool on_mover = false;
        slots.ok[s] = measure(world, origin, d_lidar, R * d_lidar, key, instant, slots.p[s], slots.intensity[s], on_mover);
        slots.mover[s] = on_mover;
      }
    }
  });
  return compact(
      slots, t_end_nominal, [&](std::size_t s) { return column_time(s / n_beams); },
      [&](std::size_t s) { return s % n_beams; }, hit_mover);
}

// A solid-state rosette: all lines fire together at each firing instant; the pattern runs on the
// sensor's clock since the start of the drive, so each frame traces new paths. The point rate
// follows the horizontal resolution knob (0.2 deg = the datasheet rate) so tests can thin it.
Sweep render_rosette(const World& world, const SimLidar& lidar, std::size_t k, std::vector<std::uint8_t>* hit_mover) {
  const SimConfig& c = world.config;
  const LidarModel& m = lidar.model;
  const std::size_t lines = static_cast<std::size_t>(std::max(1, m.lines));
  const double period_s = 1.0 / lidar.frame_rate_hz;
  const double rate_hz = m.point_rate_hz * (0.2 / c.azimuth_step_deg) / static_cast<double>(lines);
  const std::size_t n_fire = std::max<std::size_t>(1, static_cast<std::size_t>(std::llround(rate_hz * period_s)));
  const double fire_dt_s = period_s / static_cast<double>(n_fire);
  const double t_end_nominal = lidar.frame_times_s.at(k);
  const double t_start_s = lidar.frame_times_s.front() - period_s;  // the pattern's origin
  auto fire_time = [&](std::size_t f) { return t_end_nominal - static_cast<double>(n_fire - 1 - f) * fire_dt_s; };
  const bool movers = world.traffic && !world.traffic->movers.empty();
  const Body body(world);
  Slots slots(n_fire * lines);

  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n_fire, 256), [&](const tbb::blocked_range<std::size_t>& r) {
    Instant instant;
    for (std::size_t f = r.begin(); f < r.end(); ++f) {
      const double t = fire_time(f), t_ins = t + lidar.time_offset_s;
      const Iso3 T_world_ins = world.poses_true.T_world_ins(t_ins);
      const Iso3 T_world_lidar = T_world_ins * lidar.T_ins_lidar_true;
      if (movers) world.traffic->place(t_ins, world.scene->ground, instant.movers);  // culled per ray
      body.at(T_world_ins, instant);
      for (std::size_t l = 0; l < lines; ++l) {
        const Vec3 d_lidar = rosette_direction(m, static_cast<int>(l), t - t_start_s);
        const std::size_t s = f * lines + l;
        bool on_mover = false;
        slots.ok[s] = measure(world, T_world_lidar.translation(), d_lidar, T_world_lidar.linear() * d_lidar,
                              hash_counters(lidar.noise_seed, k, f, l), instant, slots.p[s], slots.intensity[s], on_mover);
        slots.mover[s] = on_mover;
      }
    }
  });
  return compact(
      slots, t_end_nominal, [&](std::size_t s) { return fire_time(s / lines); }, [&](std::size_t s) { return s % lines; },
      hit_mover);
}

}  // namespace

Sweep render_lidar_sweep(const World& world, std::size_t lidar, std::size_t k, std::vector<std::uint8_t>* hit_mover) {
  const SimLidar& l = world.lidars.at(lidar);
  if (l.model.pattern == ScanPattern::kRosette) return render_rosette(world, l, k, hit_mover);
  return render_spinning(world, l, k, hit_mover);
}

Sweep render_sweep(const World& world, std::size_t k, std::vector<std::uint8_t>* hit_mover) {
  return render_lidar_sweep(world, 0, k, hit_mover);
}

}  // namespace insalign::sim
