#include "sim/traffic.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "sim/random.hpp"

namespace insalign::sim {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kStepM = 0.5;  // route sampling
// Lane centres from the driven path (the ego drives the centre line; the scene keeps 3.5 m
// clear and puts curbs at 4.5 m): vehicles keep right at 2.2 m, cyclists ride at 3.8 m, people
// walk on the sidewalk beyond the curb at 5.3 m.
constexpr double kVehicleLaneM = 2.2;
constexpr double kBikeLaneM = 3.8;
constexpr double kSidewalkM = 5.3;
constexpr double kGridS = 0.05;        // time step of the collision checks
constexpr double kAppearFromEgoM = 15.0;  // movers appear and vanish no nearer to the ego
constexpr int kAttempts = 80;

struct Footprint {
  MoverPose pose;
  Vec2 half_m;
};

bool overlap(const Footprint& a, const Footprint& b, double margin_m) {
  const Vec2 d = b.pose.xy - a.pose.xy;
  if (d.norm() > a.half_m.norm() + b.half_m.norm() + margin_m) return false;
  const Vec2 ua(std::cos(a.pose.yaw_rad), std::sin(a.pose.yaw_rad)), va(-ua.y(), ua.x());
  const Vec2 ub(std::cos(b.pose.yaw_rad), std::sin(b.pose.yaw_rad)), vb(-ub.y(), ub.x());
  for (const Vec2& axis : {ua, va, ub, vb}) {  // separating axis theorem
    const double ra = a.half_m.x() * std::abs(ua.dot(axis)) + a.half_m.y() * std::abs(va.dot(axis)) + margin_m;
    const double rb = b.half_m.x() * std::abs(ub.dot(axis)) + b.half_m.y() * std::abs(vb.dot(axis));
    if (std::abs(d.dot(axis)) > ra + rb) return false;
  }
  return true;
}

Vec2 footprint_half(const Mover& m) { return m.half_m.head<2>(); }

// The driven path resampled every kStepM with unit normals (left of the direction of travel).
struct Road {
  std::vector<Vec2> p, n;
  bool closed = false;
  std::size_t size() const { return p.size(); }
  std::size_t wrap(long long i) const {
    const long long m = static_cast<long long>(p.size());
    return static_cast<std::size_t>(closed ? ((i % m) + m) % m : std::clamp<long long>(i, 0, m - 1));
  }
  Vec2 lane(std::size_t i, double offset_m) const { return p[i] + offset_m * n[i]; }
};

Road make_road(const std::vector<Vec2>& path) {
  Road r;
  for (const Vec2& q : path)
    if (r.p.empty() || (q - r.p.back()).norm() >= kStepM) r.p.push_back(q);
  if (r.p.size() < 2) r.p = {Vec2::Zero(), Vec2(kStepM, 0.0)};
  r.closed = r.p.size() > 100 && (r.p.front() - r.p.back()).norm() < 3.0;
  for (std::size_t i = 0; i < r.p.size(); ++i) {
    const Vec2 d = r.p[r.wrap(static_cast<long long>(i) + 1)] - r.p[r.wrap(static_cast<long long>(i) - 1)];
    const Vec2 t = d.norm() > 1e-9 ? Vec2(d / d.norm()) : Vec2(1, 0);
    r.n.push_back(Vec2(-t.y(), t.x()));
  }
  return r;
}

// Whether an upright body (half length and width, height) standing at c with heading `yaw`, grown
// by a margin, is free of static geometry. A ray starting inside a primitive does not see it, so:
// rays along its length both ways, closer together across its width than the thinnest pole
// (0.16 m), at three heights; and rays down from just above it over a 0.4 m grid (anything
// standing there, even something that holds the whole body; curbs up to 0.2 m are stepped over).
bool clear_footprint(const Scene& scene, const Vec2& c, double yaw, const Vec2& half_m, double height_m) {
  const Vec2 u(std::cos(yaw), std::sin(yaw)), v(-u.y(), u.x());
  const double hl = half_m.x() + 0.15, hw = half_m.y() + 0.1;
  const double zg = scene.ground.z_at(c.x(), c.y());
  const int n = static_cast<int>(std::ceil(2.0 * hw / 0.12));
  for (int i = 0; i <= n; ++i) {
    const Vec2 lateral = (-hw + 2.0 * hw * i / n) * v;
    for (double z : {0.4, 0.5 * (0.4 + height_m), std::max(0.5, height_m - 0.1)})
      for (double sign : {-1.0, 1.0}) {
        const Vec2 o = c + lateral - sign * hl * u;
        if (scene.cast(Vec3(o.x(), o.y(), zg + z), Vec3(sign * u.x(), sign * u.y(), 0.0), 2.0 * hl)) return false;
      }
  }
  const int na = static_cast<int>(std::ceil(2.0 * hl / 0.4)), nb = static_cast<int>(std::ceil(2.0 * hw / 0.4));
  const double top_m = height_m + 0.05;
  for (int ia = 0; ia <= na; ++ia)
    for (int ib = 0; ib <= nb; ++ib) {
      const Vec2 o = c + (-hl + 2.0 * hl * ia / na) * u + (-hw + 2.0 * hw * ib / nb) * v;
      const auto hit = scene.cast(Vec3(o.x(), o.y(), scene.ground.z_at(o.x(), o.y()) + top_m), -Vec3::UnitZ(), top_m);
      if (hit && hit->range_m < top_m - 0.2) return false;
    }
  return true;
}

// Static clearance of a body of the lane's largest size at each road sample, computed once.
struct Lane {
  double offset_m = 0.0;
  std::vector<std::uint8_t> clear;  ///< per road sample
};
Lane make_lane(const Scene& scene, const Road& road, double offset_m, const Vec2& half_m, double height_m) {
  Lane lane{offset_m, std::vector<std::uint8_t>(road.size(), 0)};
  for (std::size_t i = 0; i < road.size(); ++i) {
    const double yaw = std::atan2(-road.n[i].x(), road.n[i].y());  // along the road
    lane.clear[i] = clear_footprint(scene, road.lane(i, offset_m), yaw, half_m, height_m);
  }
  return lane;
}

// Appends `count` samples of a lane starting at road index i0, stepping dir (+1/-1); false when
// blocked or off the end of an open road.
bool follow_lane(const Road& road, const Lane& lane, long long i0, int dir, int count, std::vector<Vec2>& out) {
  for (int k = 0; k < count; ++k) {
    const long long i = i0 + static_cast<long long>(dir) * k;
    if (!road.closed && (i < 0 || i >= static_cast<long long>(road.size()))) return false;
    const std::size_t a = road.wrap(i);
    if (!lane.clear[a]) return false;
    out.push_back(road.lane(a, lane.offset_m));
  }
  return true;
}

void finish_route(Mover& m) {
  m.route_s_m.assign(1, 0.0);
  for (std::size_t i = 1; i < m.route_xy.size(); ++i)
    m.route_s_m.push_back(m.route_s_m.back() + (m.route_xy[i] - m.route_xy[i - 1]).norm());
}

struct Context {
  const Scene& scene;
  const Road& road;
  Rng& rng;
  std::vector<Lane> vehicle_lanes, bike_lanes, sidewalks;  // [0]: right of travel (+1), [1]: left
};

// A route along a lane; the side keeps right of the direction of travel for vehicles and bikes.
bool lane_route(Context& c, const std::vector<Lane>& lanes, bool keep_right, double length_m, Mover& m) {
  const int dir = c.rng.uniform() < 0.5 ? 1 : -1;
  const int side = keep_right ? (dir > 0 ? 0 : 1) : (c.rng.uniform() < 0.5 ? 0 : 1);
  const int count = std::max(2, static_cast<int>(length_m / kStepM));
  long long i0 = static_cast<long long>(c.rng.uniform(0.0, static_cast<double>(c.road.size())));
  if (!c.road.closed) {  // an open street: start far enough from the end to fit
    const long long n = static_cast<long long>(c.road.size());
    if (count >= n) return false;
    i0 = dir > 0 ? i0 % (n - count) : n - 1 - i0 % (n - count);
  }
  m.route_xy.clear();
  if (!follow_lane(c.road, lanes[side], i0, dir, count, m.route_xy)) return false;
  finish_route(m);
  return true;
}

// Sidewalk, across the road (perpendicular), sidewalk on the other side.
bool crossing_route(Context& c, Mover& m) {
  const Road& road = c.road;
  const long long i = static_cast<long long>(c.rng.uniform(0.0, static_cast<double>(road.size())));
  const int from = c.rng.uniform() < 0.5 ? 0 : 1;  // sidewalk index: 0 right (-n), 1 left (+n)
  const int before = static_cast<int>(c.rng.uniform(0.0, 8.0) / kStepM) + 1;
  const int after = static_cast<int>(c.rng.uniform(0.0, 8.0) / kStepM) + 1;
  const int dir = c.rng.uniform() < 0.5 ? 1 : -1;
  m.route_xy.clear();
  if (!follow_lane(road, c.sidewalks[from], i - dir * (before - 1), dir, before, m.route_xy)) return false;
  const std::size_t at = road.wrap(i);
  const Vec2 a = road.lane(at, c.sidewalks[from].offset_m), b = road.lane(at, c.sidewalks[1 - from].offset_m);
  const int steps = static_cast<int>((b - a).norm() / kStepM);
  const double yaw = std::atan2(b.y() - a.y(), b.x() - a.x());
  for (int k = 1; k <= steps; ++k) {
    const Vec2 q = a + (b - a) * (static_cast<double>(k) / steps);
    if (!clear_footprint(c.scene, q, yaw, Vec2(0.3, 0.3), 2.0 * m.half_m.z())) return false;
    m.route_xy.push_back(q);
  }
  std::vector<Vec2> rest;
  if (!follow_lane(road, c.sidewalks[1 - from], i, dir, after, rest)) return false;
  m.route_xy.insert(m.route_xy.end(), rest.begin() + 1, rest.end());
  finish_route(m);
  return m.route_xy.size() >= 2;
}

// Size, speed and route of one mover of the given kind; false if its route is blocked.
bool draw_mover(Context& c, MoverKind kind, Mover& m) {
  Rng& rng = c.rng;
  m.kind = kind;
  const double loop_m = kStepM * static_cast<double>(c.road.size());
  switch (kind) {
    case MoverKind::kCar:
      m.half_m = 0.5 * Vec3(rng.uniform(4.0, 4.9), rng.uniform(1.7, 1.95), rng.uniform(1.4, 1.6));
      break;
    case MoverKind::kVan:
      m.half_m = 0.5 * Vec3(rng.uniform(5.0, 6.0), rng.uniform(1.95, 2.1), rng.uniform(2.0, 2.5));
      break;
    case MoverKind::kCyclist: m.half_m = 0.5 * Vec3(1.75, 0.6, 1.7); break;
    case MoverKind::kPedestrian: {
      const double r = rng.uniform(0.22, 0.3);
      m.half_m = Vec3(r, r, 0.5 * rng.uniform(1.5, 1.9));
      break;
    }
  }
  m.reflectivity = static_cast<float>(kind == MoverKind::kPedestrian ? rng.uniform(0.2, 0.5) : rng.uniform(0.2, 0.9));
  if (kind == MoverKind::kCar || kind == MoverKind::kVan) {
    m.speed_mps = rng.uniform(15.0, 40.0) / 3.6;
    return lane_route(c, c.vehicle_lanes, true, rng.uniform(60.0, std::max(80.0, std::min(250.0, 1.2 * loop_m))), m);
  }
  if (kind == MoverKind::kCyclist) {
    m.speed_mps = rng.uniform(3.0, 6.0);
    return lane_route(c, c.bike_lanes, true, rng.uniform(40.0, 150.0), m);
  }
  m.speed_mps = rng.uniform() < 0.15 ? rng.uniform(2.5, 3.5) : rng.uniform(1.0, 1.8);  // some joggers
  if (rng.uniform() < 0.4) return crossing_route(c, m);
  return lane_route(c, c.sidewalks, false, rng.uniform(15.0, 60.0), m);
}

// Footprints of accepted movers on the global time grid.
struct Schedule {
  double t0_s = 0.0;
  std::vector<Footprint> ego;  // one per grid step
  struct Entry {
    std::size_t first = 0;
    std::vector<Footprint> steps;
    bool vehicle = false;
  };
  std::vector<Entry> movers;
  std::size_t index(double t_s) const { return static_cast<std::size_t>(std::max(0.0, std::ceil((t_s - t0_s) / kGridS))); }
};

Schedule::Entry sample(const Schedule& s, const Mover& m) {
  Schedule::Entry e;
  e.first = s.index(m.t_start_s);
  e.vehicle = m.kind == MoverKind::kCar || m.kind == MoverKind::kVan;
  for (std::size_t g = e.first; g < s.ego.size(); ++g) {
    const auto pose = mover_pose(m, s.t0_s + static_cast<double>(g) * kGridS);
    if (!pose) break;
    e.steps.push_back({*pose, footprint_half(m)});
  }
  return e;
}

// Margins between bodies: more around vehicles, little between people.
double margin(bool a_vehicle, bool b_vehicle) { return a_vehicle || b_vehicle ? 0.5 : 0.15; }

bool fits(const Schedule& s, const Schedule::Entry& e) {
  if (e.steps.empty()) return false;  // never on the road during the drive
  // Appear and vanish out of the ego's immediate view.
  for (std::size_t k : {std::size_t{0}, e.steps.size() - 1}) {
    const std::size_t g = e.first + k;
    if ((e.steps[k].pose.xy - s.ego[g].pose.xy).norm() < kAppearFromEgoM) return false;
  }
  for (std::size_t k = 0; k < e.steps.size(); ++k) {
    const std::size_t g = e.first + k;
    if (overlap(e.steps[k], s.ego[g], 0.5)) return false;
    for (const Schedule::Entry& o : s.movers) {
      if (g < o.first || g >= o.first + o.steps.size()) continue;
      if (overlap(e.steps[k], o.steps[g - o.first], margin(e.vehicle, o.vehicle))) return false;
    }
  }
  return true;
}

}  // namespace

std::optional<MoverPose> mover_pose(const Mover& m, double t_s) {
  const double s = m.speed_mps * (t_s - m.t_start_s);
  if (m.route_xy.size() < 2 || s < 0.0 || s > m.route_s_m.back()) return std::nullopt;
  const auto it = std::upper_bound(m.route_s_m.begin(), m.route_s_m.end(), s);
  const std::size_t i = std::min<std::size_t>(m.route_xy.size() - 1, std::max<std::size_t>(1, it - m.route_s_m.begin()));
  const Vec2 a = m.route_xy[i - 1], b = m.route_xy[i];
  const double seg = m.route_s_m[i] - m.route_s_m[i - 1];
  const double f = seg > 1e-12 ? (s - m.route_s_m[i - 1]) / seg : 0.0;
  return MoverPose{a + f * (b - a), std::atan2(b.y() - a.y(), b.x() - a.x())};
}

void Traffic::place(double t_s, const GroundPlane& ground, std::vector<PlacedMover>& out) const {
  out.clear();
  for (const Mover& m : movers) {
    const auto pose = mover_pose(m, t_s);
    if (!pose) continue;
    PlacedMover p;
    const double zg = ground.z_at(pose->xy.x(), pose->xy.y());
    const double height = 2.0 * m.half_m.z();
    auto box = [&](double along_m, double len, double wid, double z0, double z1) {
      const Vec2 c = pose->xy + along_m * Vec2(std::cos(pose->yaw_rad), std::sin(pose->yaw_rad));
      Box b{Vec3(c.x(), c.y(), zg + 0.5 * (z0 + z1)), pose->yaw_rad, Vec3(0.5 * len, 0.5 * wid, 0.5 * (z1 - z0)), m.reflectivity,
            BoxKind::kCar};
      p.boxes[p.n_boxes++] = b;
    };
    const double len = 2.0 * m.half_m.x(), wid = 2.0 * m.half_m.y();
    if (m.kind == MoverKind::kCar) {  // body and a narrower cabin, as the parked cars
      box(0.0, len, wid, 0.2, 1.0);
      box(-0.1 * len, 0.55 * len, 0.85 * wid, 1.0, height);
    } else if (m.kind == MoverKind::kVan) {
      box(0.0, len, wid, 0.2, height);
    } else if (m.kind == MoverKind::kCyclist) {
      box(0.0, len, wid, 0.05, height);
    } else {
      p.cylinder = {pose->xy, zg, zg + height, m.half_m.x(), m.reflectivity};
    }
    p.center_m = Vec3(pose->xy.x(), pose->xy.y(), zg + 0.5 * height);
    p.radius_m = m.half_m.norm() + 0.05;
    out.push_back(p);
  }
}

std::optional<RayHit> cast_movers(const std::vector<PlacedMover>& candidates, const Vec3& origin, const Vec3& dir,
                                  double max_range_m) {
  double best = max_range_m;
  std::optional<RayHit> hit;
  for (const PlacedMover& p : candidates) {
    const Vec3 oc = p.center_m - origin;
    const double along = oc.dot(dir);
    if (along < -p.radius_m || along - p.radius_m > best) continue;
    if (oc.squaredNorm() - along * along > p.radius_m * p.radius_m) continue;
    double t = 0.0;
    Vec3 n;
    if (p.n_boxes == 0) {
      if (hit_cylinder(p.cylinder, origin, dir, best, t, n) && t < best) {
        best = t;
        hit = RayHit{t, n, p.cylinder.reflectivity};
      }
      continue;
    }
    for (int b = 0; b < p.n_boxes; ++b) {
      if (hit_box(p.boxes[b], origin, dir, best, t, n) && t < best) {
        best = t;
        hit = RayHit{t, n, p.boxes[b].reflectivity};
      }
    }
  }
  return hit;
}

Traffic make_traffic(const TrafficRequest& request, const Scene& scene, const EgoFootprint& ego) {
  Traffic traffic;
  if (request.vehicles <= 0 && request.people <= 0) return traffic;
  Rng rng(request.seed);
  const Road road = make_road(request.path_xy);
  Context c{scene, road, rng, {}, {}, {}};
  for (double side : {-1.0, 1.0}) {  // index 0: right of the road's direction (-n)
    // The largest body of each lane: a 6 m van, a bike, a person.
    c.vehicle_lanes.push_back(make_lane(scene, road, side * kVehicleLaneM, Vec2(3.0, 1.05), 2.5));
    c.bike_lanes.push_back(make_lane(scene, road, side * kBikeLaneM, Vec2(0.875, 0.3), 1.7));
    c.sidewalks.push_back(make_lane(scene, road, side * kSidewalkM, Vec2(0.3, 0.3), 1.9));
  }
  Schedule schedule;
  schedule.t0_s = request.t_begin_s - 1.0;
  for (double t = schedule.t0_s; t <= request.t_end_s + 1.0; t += kGridS) schedule.ego.push_back({ego.pose(t), ego.half_m});

  std::vector<MoverKind> kinds;
  for (int i = 0; i < request.vehicles; ++i) kinds.push_back(rng.uniform() < 0.25 ? MoverKind::kVan : MoverKind::kCar);
  for (int i = 0; i < request.people; ++i) kinds.push_back(rng.uniform() < 0.3 ? MoverKind::kCyclist : MoverKind::kPedestrian);
  for (MoverKind kind : kinds) {
    for (int attempt = 0; attempt < kAttempts; ++attempt) {
      Mover m;
      if (!draw_mover(c, kind, m)) continue;
      const double life_s = m.route_s_m.back() / m.speed_mps;
      m.t_start_s = rng.uniform(request.t_begin_s - 0.5 * life_s, request.t_end_s - 0.5 * life_s);
      Schedule::Entry entry = sample(schedule, m);
      if (!fits(schedule, entry)) continue;
      schedule.movers.push_back(std::move(entry));
      traffic.movers.push_back(std::move(m));
      break;
    }
  }
  return traffic;
}

}  // namespace insalign::sim
