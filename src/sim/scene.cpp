#include "sim/scene.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numbers>

#include "sim/random.hpp"

namespace insalign::sim {
namespace {

constexpr double kPi = std::numbers::pi;
enum PrimKind : std::uint32_t { kBoxPrim = 0, kCylinderPrim = 1, kSpherePrim = 2 };

struct Aabb {
  Vec3 lo = Vec3::Constant(std::numeric_limits<double>::infinity());
  Vec3 hi = Vec3::Constant(-std::numeric_limits<double>::infinity());
  void grow(const Aabb& o) {
    lo = lo.cwiseMin(o.lo);
    hi = hi.cwiseMax(o.hi);
  }
  Vec3 center() const { return 0.5 * (lo + hi); }
};

Aabb bounds(const Box& b) {
  const double c = std::abs(std::cos(b.yaw_rad)), s = std::abs(std::sin(b.yaw_rad));
  const Vec3 ext(c * b.half_m.x() + s * b.half_m.y(), s * b.half_m.x() + c * b.half_m.y(), b.half_m.z());
  return {b.center_m - ext, b.center_m + ext};
}
Aabb bounds(const Cylinder& c) {
  return {Vec3(c.center_m.x() - c.radius_m, c.center_m.y() - c.radius_m, c.z0_m),
          Vec3(c.center_m.x() + c.radius_m, c.center_m.y() + c.radius_m, c.z1_m)};
}
Aabb bounds(const Sphere& s) {
  return {s.center_m - Vec3::Constant(s.radius_m), s.center_m + Vec3::Constant(s.radius_m)};
}

bool hit_sphere(const Sphere& sp, const Vec3& o, const Vec3& d, double t_max, double& t_out, Vec3& n_out) {
  const Vec3 p = o - sp.center_m;
  const double b = p.dot(d);
  const double c = p.squaredNorm() - sp.radius_m * sp.radius_m;
  const double disc = b * b - c;
  if (disc < 0.0) return false;
  const double t = -b - std::sqrt(disc);
  if (t <= 1e-6 || t > t_max) return false;
  n_out = (p + t * d) / sp.radius_m;
  t_out = t;
  return true;
}

// Slab test against a float AABB; returns the entry distance or +inf.
inline float aabb_entry(const Scene::Node& n, const Eigen::Vector3f& o, const Eigen::Vector3f& inv_d, float t_max) {
  float t0 = 0.0f, t1 = t_max;
  for (int a = 0; a < 3; ++a) {
    float ta = (n.lo[a] - o[a]) * inv_d[a], tb = (n.hi[a] - o[a]) * inv_d[a];
    if (ta > tb) std::swap(ta, tb);
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
  }
  return t0 <= t1 ? t0 : std::numeric_limits<float>::infinity();
}

}  // namespace

// Ray against an upright yawed box: slab test in the box frame.
bool hit_box(const Box& b, const Vec3& o, const Vec3& d, double t_max, double& t_out, Vec3& n_out) {
  const double c = std::cos(b.yaw_rad), s = std::sin(b.yaw_rad);
  const Vec3 p = o - b.center_m;
  const Vec3 lo(c * p.x() + s * p.y(), -s * p.x() + c * p.y(), p.z());
  const Vec3 ld(c * d.x() + s * d.y(), -s * d.x() + c * d.y(), d.z());
  double t0 = 1e-6, t1 = t_max;
  int axis = -1;
  double sign = 0.0;
  for (int a = 0; a < 3; ++a) {
    if (std::abs(ld[a]) < 1e-12) {
      if (std::abs(lo[a]) > b.half_m[a]) return false;
      continue;
    }
    const double inv = 1.0 / ld[a];
    double ta = (-b.half_m[a] - lo[a]) * inv, tb = (b.half_m[a] - lo[a]) * inv;
    double entry_sign = -1.0;  // entering through the -half face
    if (ta > tb) {
      std::swap(ta, tb);
      entry_sign = 1.0;
    }
    if (ta > t0) {
      t0 = ta;
      axis = a;
      sign = entry_sign;
    }
    t1 = std::min(t1, tb);
    if (t0 > t1) return false;
  }
  if (axis < 0) return false;  // origin inside the box: no return (sensor never sits inside geometry)
  Vec3 ln = Vec3::Zero();
  ln[axis] = sign;
  n_out = Vec3(c * ln.x() - s * ln.y(), s * ln.x() + c * ln.y(), ln.z());
  t_out = t0;
  return true;
}

bool hit_cylinder(const Cylinder& cy, const Vec3& o, const Vec3& d, double t_max, double& t_out, Vec3& n_out) {
  const double px = o.x() - cy.center_m.x(), py = o.y() - cy.center_m.y();
  const double a = d.x() * d.x() + d.y() * d.y();
  if (a < 1e-12) return false;
  const double b = px * d.x() + py * d.y();
  const double c = px * px + py * py - cy.radius_m * cy.radius_m;
  const double disc = b * b - a * c;
  if (disc < 0.0) return false;
  const double t = (-b - std::sqrt(disc)) / a;
  if (t <= 1e-6 || t > t_max) return false;
  const double z = o.z() + t * d.z();
  if (z < cy.z0_m || z > cy.z1_m) return false;
  n_out = Vec3(px + t * d.x(), py + t * d.y(), 0.0) / cy.radius_m;
  t_out = t;
  return true;
}

void Scene::finalize() {
  // BVH over all primitives: median split on the widest centroid axis, leaves of up to 4.
  std::vector<Aabb> prim_bounds;
  refs.clear();
  for (std::size_t i = 0; i < boxes.size(); ++i) {
    refs.push_back({kBoxPrim, static_cast<std::uint32_t>(i)});
    prim_bounds.push_back(bounds(boxes[i]));
  }
  for (std::size_t i = 0; i < cylinders.size(); ++i) {
    refs.push_back({kCylinderPrim, static_cast<std::uint32_t>(i)});
    prim_bounds.push_back(bounds(cylinders[i]));
  }
  for (std::size_t i = 0; i < spheres.size(); ++i) {
    refs.push_back({kSpherePrim, static_cast<std::uint32_t>(i)});
    prim_bounds.push_back(bounds(spheres[i]));
  }
  std::vector<std::uint32_t> order(refs.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = static_cast<std::uint32_t>(i);
  nodes.clear();
  nodes.reserve(2 * refs.size() + 1);

  auto build = [&](auto&& self, std::size_t begin, std::size_t end) -> void {
    Aabb box, centroids;
    for (std::size_t i = begin; i < end; ++i) {
      box.grow(prim_bounds[order[i]]);
      const Vec3 c = prim_bounds[order[i]].center();
      centroids.grow({c, c});
    }
    const std::size_t me = nodes.size();
    nodes.push_back({box.lo.cast<float>(), box.hi.cast<float>(), 0, 0});
    if (end - begin <= 4) {
      nodes[me].first_or_right = static_cast<std::uint32_t>(begin);
      nodes[me].count = static_cast<std::uint32_t>(end - begin);
      return;
    }
    int axis = 0;
    (centroids.hi - centroids.lo).maxCoeff(&axis);
    const std::size_t mid = (begin + end) / 2;
    std::nth_element(order.begin() + begin, order.begin() + mid, order.begin() + end,
                     [&](std::uint32_t a, std::uint32_t b) {
                       return prim_bounds[a].center()[axis] < prim_bounds[b].center()[axis];
                     });
    self(self, begin, mid);
    nodes[me].first_or_right = static_cast<std::uint32_t>(nodes.size());
    self(self, mid, end);
  };
  if (!refs.empty()) build(build, 0, refs.size());
  std::vector<PrimRef> sorted(refs.size());
  for (std::size_t i = 0; i < order.size(); ++i) sorted[i] = refs[order[i]];
  refs = std::move(sorted);

  // Marking lookup grid.
  marking_cells.clear();
  marking_nx = marking_ny = 0;
  if (markings.empty()) return;
  Vec2 lo = Vec2::Constant(1e18), hi = Vec2::Constant(-1e18);
  for (const Marking& m : markings) {
    const double r = m.half_length_m + m.half_width_m;
    lo = lo.cwiseMin(m.center_m - Vec2::Constant(r));
    hi = hi.cwiseMax(m.center_m + Vec2::Constant(r));
  }
  marking_grid_origin_m = lo;
  marking_nx = static_cast<int>((hi.x() - lo.x()) / marking_cell_m) + 1;
  marking_ny = static_cast<int>((hi.y() - lo.y()) / marking_cell_m) + 1;
  marking_cells.assign(static_cast<std::size_t>(marking_nx) * marking_ny, {});
  for (std::size_t i = 0; i < markings.size(); ++i) {
    const Marking& m = markings[i];
    const double r = m.half_length_m + m.half_width_m;
    const int x0 = static_cast<int>((m.center_m.x() - r - lo.x()) / marking_cell_m);
    const int x1 = static_cast<int>((m.center_m.x() + r - lo.x()) / marking_cell_m);
    const int y0 = static_cast<int>((m.center_m.y() - r - lo.y()) / marking_cell_m);
    const int y1 = static_cast<int>((m.center_m.y() + r - lo.y()) / marking_cell_m);
    for (int y = std::max(0, y0); y <= std::min(marking_ny - 1, y1); ++y)
      for (int x = std::max(0, x0); x <= std::min(marking_nx - 1, x1); ++x)
        marking_cells[static_cast<std::size_t>(y) * marking_nx + x].push_back(static_cast<std::uint32_t>(i));
  }
}

bool Scene::on_marking(double x, double y) const {
  if (marking_cells.empty()) return false;
  const int cx = static_cast<int>(std::floor((x - marking_grid_origin_m.x()) / marking_cell_m));
  const int cy = static_cast<int>(std::floor((y - marking_grid_origin_m.y()) / marking_cell_m));
  if (cx < 0 || cy < 0 || cx >= marking_nx || cy >= marking_ny) return false;
  for (std::uint32_t i : marking_cells[static_cast<std::size_t>(cy) * marking_nx + cx]) {
    const Marking& m = markings[i];
    const double dx = x - m.center_m.x(), dy = y - m.center_m.y();
    const double c = std::cos(m.yaw_rad), s = std::sin(m.yaw_rad);
    if (std::abs(c * dx + s * dy) <= m.half_length_m && std::abs(-s * dx + c * dy) <= m.half_width_m) return true;
  }
  return false;
}

std::optional<RayHit> Scene::cast(const Vec3& origin, const Vec3& dir, double max_range_m) const {
  double best = max_range_m;
  RayHit hit;
  bool found = false;

  // Ground first: it bounds the search for everything else.
  const double denom = dir.z() - ground.slope_x * dir.x() - ground.slope_y * dir.y();
  if (denom < -1e-9) {
    const double t = (ground.z_at(origin.x(), origin.y()) - origin.z()) / denom;
    if (t > 1e-6 && t <= best) {
      best = t;
      found = true;
      hit.normal = ground.normal();
      const Vec3 p = origin + t * dir;
      hit.reflectivity = on_marking(p.x(), p.y()) ? 0.85f : 0.12f;
    }
  }

  if (!nodes.empty()) {
    const Eigen::Vector3f o = origin.cast<float>();
    Eigen::Vector3f inv_d;
    for (int a = 0; a < 3; ++a) {
      const double da = std::abs(dir[a]) < 1e-12 ? (dir[a] < 0 ? -1e-12 : 1e-12) : dir[a];
      inv_d[a] = static_cast<float>(1.0 / da);
    }
    std::array<std::uint32_t, 64> stack;
    int top = 0;
    stack[top++] = 0;
    while (top > 0) {
      const Node& node = nodes[stack[--top]];
      // Float boxes: pad the search range so rounding never culls a real hit.
      if (aabb_entry(node, o, inv_d, static_cast<float>(best) + 1e-3f) == std::numeric_limits<float>::infinity())
        continue;
      if (node.count > 0) {
        for (std::uint32_t i = node.first_or_right; i < node.first_or_right + node.count; ++i) {
          const PrimRef ref = refs[i];
          double t = 0.0;
          Vec3 n;
          bool h = false;
          float refl = 0.0f;
          if (ref.kind == kBoxPrim) {
            h = hit_box(boxes[ref.index], origin, dir, best, t, n);
            refl = boxes[ref.index].reflectivity;
          } else if (ref.kind == kCylinderPrim) {
            h = hit_cylinder(cylinders[ref.index], origin, dir, best, t, n);
            refl = cylinders[ref.index].reflectivity;
          } else {
            h = hit_sphere(spheres[ref.index], origin, dir, best, t, n);
            refl = spheres[ref.index].reflectivity;
          }
          if (h && t < best) {
            best = t;
            found = true;
            hit.normal = n;
            hit.reflectivity = refl;
          }
        }
        continue;
      }
      const std::uint32_t left = static_cast<std::uint32_t>(&node - nodes.data()) + 1;
      const std::uint32_t right = node.first_or_right;
      // Visit the nearer child first.
      const float tl = aabb_entry(nodes[left], o, inv_d, static_cast<float>(best) + 1e-3f);
      const float tr = aabb_entry(nodes[right], o, inv_d, static_cast<float>(best) + 1e-3f);
      const bool l_ok = tl != std::numeric_limits<float>::infinity();
      const bool r_ok = tr != std::numeric_limits<float>::infinity();
      if (l_ok && r_ok && top + 2 <= static_cast<int>(stack.size())) {
        if (tl < tr) {
          stack[top++] = right;
          stack[top++] = left;
        } else {
          stack[top++] = left;
          stack[top++] = right;
        }
      } else if (l_ok && top < static_cast<int>(stack.size())) {
        stack[top++] = left;
      } else if (r_ok && top < static_cast<int>(stack.size())) {
        stack[top++] = right;
      }
    }
  }
  if (!found) return std::nullopt;
  hit.range_m = best;
  return hit;
}

// ---------------------------------------------------------------------------------------------
// Scene generation.
namespace {

/// Occupancy on a 0.5 m grid: the driving corridor and what is already placed.
class Layout {
 public:
  Layout(const std::vector<Vec2>& path_xy, double corridor_m, double margin_m) : path_(path_xy) {
    lo_ = Vec2::Constant(1e18);
    hi_ = Vec2::Constant(-1e18);
    for (const Vec2& p : path_xy) {
      lo_ = lo_.cwiseMin(p);
      hi_ = hi_.cwiseMax(p);
    }
    lo_ -= Vec2::Constant(margin_m);
    hi_ += Vec2::Constant(margin_m);
    nx_ = static_cast<int>((hi_.x() - lo_.x()) / kCell) + 1;
    ny_ = static_cast<int>((hi_.y() - lo_.y()) / kCell) + 1;
    dist_.assign(static_cast<std::size_t>(nx_) * ny_, 1e9f);
    taken_.assign(dist_.size(), 0);
    // Distance to the path, exact within reach_m (enough for every placement rule).
    const double reach_m = 40.0;
    const int r = static_cast<int>(reach_m / kCell);
    Vec2 last(1e18, 1e18);
    for (const Vec2& p : path_xy) {
      if ((p - last).norm() < 0.5) continue;
      last = p;
      const int cx = cell_x(p.x()), cy = cell_y(p.y());
      for (int y = std::max(0, cy - r); y <= std::min(ny_ - 1, cy + r); ++y)
        for (int x = std::max(0, cx - r); x <= std::min(nx_ - 1, cx + r); ++x) {
          const double d = (Vec2(lo_.x() + (x + 0.5) * kCell, lo_.y() + (y + 0.5) * kCell) - p).norm();
          float& cell = dist_[static_cast<std::size_t>(y) * nx_ + x];
          cell = std::min(cell, static_cast<float>(d));
        }
    }
    corridor_m_ = corridor_m;
  }
  const Vec2& lo() const { return lo_; }
  const Vec2& hi() const { return hi_; }
  double path_distance(const Vec2& p) const {
    const int x = cell_x(p.x()), y = cell_y(p.y());
    if (x < 0 || y < 0 || x >= nx_ || y >= ny_) return 1e9;
    return dist_[static_cast<std::size_t>(y) * nx_ + x];
  }
  /// Whether an oriented rectangle (grown by pad_m) keeps min_path_m from the path and is free.
  bool free(const Vec2& c, double yaw, double half_l, double half_w, double min_path_m, double pad_m = 0.3) const {
    bool ok = true;
    visit(c, yaw, half_l + pad_m, half_w + pad_m, [&](std::size_t i) {
      if (dist_[i] < min_path_m || taken_[i]) ok = false;
    });
    return ok;
  }
  void take(const Vec2& c, double yaw, double half_l, double half_w) {
    visit(c, yaw, half_l, half_w, [&](std::size_t i) { taken_[i] = 1; });
  }

 private:
  static constexpr double kCell = 0.5;
  int cell_x(double x) const { return static_cast<int>(std::floor((x - lo_.x()) / kCell)); }
  int cell_y(double y) const { return static_cast<int>(std::floor((y - lo_.y()) / kCell)); }
  template <class F>
  void visit(const Vec2& c, double yaw, double half_l, double half_w, F&& f) const {
    const Vec2 u(std::cos(yaw), std::sin(yaw)), v(-std::sin(yaw), std::cos(yaw));
    for (double a = -half_l; a <= half_l + 1e-9; a += kCell * 0.7)
      for (double b = -half_w; b <= half_w + 1e-9; b += kCell * 0.7) {
        const Vec2 p = c + a * u + b * v;
        const int x = cell_x(p.x()), y = cell_y(p.y());
        if (x < 0 || y < 0 || x >= nx_ || y >= ny_) continue;
        f(static_cast<std::size_t>(y) * nx_ + x);
      }
  }
  std::vector<Vec2> path_;
  Vec2 lo_, hi_;
  int nx_ = 0, ny_ = 0;
  std::vector<float> dist_;
  std::vector<std::uint8_t> taken_;
  double corridor_m_ = 0.0;
};

// Tangent direction of the path near sample i.
double path_heading(const std::vector<Vec2>& path, std::size_t i) {
  const std::size_t a = i == 0 ? 0 : i - 1, b = std::min(path.size() - 1, i + 1);
  const Vec2 d = path[b] - path[a];
  return d.norm() < 1e-9 ? 0.0 : std::atan2(d.y(), d.x());
}

// A point at distance [d_min, d_max] to the side of a random path sample.
Vec2 beside_path(Rng& rng, const std::vector<Vec2>& path, double d_min, double d_max, double* heading) {
  const std::size_t i = static_cast<std::size_t>(rng.uniform(0.0, static_cast<double>(path.size()) - 1e-9));
  const double h = path_heading(path, i);
  const double side = rng.uniform() < 0.5 ? -1.0 : 1.0;
  const double d = rng.uniform(d_min, d_max);
  if (heading) *heading = h;
  return path[i] + side * d * Vec2(-std::sin(h), std::cos(h)) + rng.uniform(-2.0, 2.0) * Vec2(std::cos(h), std::sin(h));
}

// Upright box resting on the ground (buried 1 m so a slope never shows a gap underneath).
Box ground_box(const GroundPlane& g, const Vec2& c, double yaw, double len, double wid, double height_m,
               double base_above_m, float refl) {
  const double zg = g.z_at(c.x(), c.y());
  const double z0 = zg + base_above_m - (base_above_m > 0.0 ? 0.0 : 1.0);
  const double z1 = zg + base_above_m + height_m;
  return {Vec3(c.x(), c.y(), 0.5 * (z0 + z1)), yaw, Vec3(0.5 * len, 0.5 * wid, 0.5 * (z1 - z0)), refl};
}

constexpr double kCorridorM = 3.5;  // half-width of the space the vehicle sweeps through, plus margin

void add_building(Scene& s, Layout& layout, Rng& rng, const std::vector<Vec2>& path, double street_yaw) {
  for (int attempt = 0; attempt < 40; ++attempt) {
    double h = 0.0;
    const Vec2 c = beside_path(rng, path, 12.0, 35.0, &h);
    // Mostly on a street grid (with jitter), sometimes free: never all axis-aligned.
    double yaw = rng.uniform() < 0.7 ? street_yaw + (kPi / 2) * rng.uniform_int(0, 3) + rng.normal(0.08)
                                     : rng.uniform(-kPi, kPi);
    const double len = rng.uniform(10.0, 30.0), dep = rng.uniform(7.0, 15.0), height = rng.uniform(6.0, 22.0);
    if (!layout.free(c, yaw, len / 2, dep / 2, 8.0, 1.0)) continue;
    layout.take(c, yaw, len / 2, dep / 2);
    const Vec2 u(std::cos(yaw), std::sin(yaw)), v(-std::sin(yaw), std::cos(yaw));
    // Front = the long side facing the path; it gets recessed segments.
    const double front = layout.path_distance(c + v * (dep / 2 + 2.0)) < layout.path_distance(c - v * (dep / 2 + 2.0))
                             ? 1.0 : -1.0;
    const double max_recess = 1.2;
    const float refl = static_cast<float>(rng.uniform(0.25, 0.6));
    s.boxes.push_back(ground_box(s.ground, c - front * v * (max_recess / 2), yaw, len, dep - max_recess, height, 0.0, refl));
    const int segments = rng.uniform_int(3, 7);
    const double seg_len = len / segments;
    for (int k = 0; k < segments; ++k) {
      const double recess = rng.uniform() < 0.5 ? 0.0 : rng.uniform(0.3, max_recess);
      const double depth = max_recess - recess;
      if (depth < 0.05) continue;
      const Vec2 sc = c + u * (-len / 2 + (k + 0.5) * seg_len) + front * v * (dep / 2 - max_recess + depth / 2);
      const double sh = height * rng.uniform(0.6, 1.0);
      s.boxes.push_back(ground_box(s.ground, sc, yaw, seg_len, depth, sh, 0.0, refl));
    }
    return;
  }
}

void add_wall(Scene& s, Layout& layout, Rng& rng, const std::vector<Vec2>& path, double d_min, double d_max) {
  for (int attempt = 0; attempt < 40; ++attempt) {
    double h = 0.0;
    const Vec2 c = beside_path(rng, path, d_min, d_max, &h);
    const double yaw = h + rng.normal(0.3);
    const double len = rng.uniform(8.0, 25.0), height = rng.uniform(1.2, 3.0);
    if (!layout.free(c, yaw, len / 2, 0.15, 6.0)) continue;
    layout.take(c, yaw, len / 2, 0.15);
    s.boxes.push_back(ground_box(s.ground, c, yaw, len, 0.25, height, 0.0, static_cast<float>(rng.uniform(0.3, 0.7))));
    s.boxes.back().kind = BoxKind::kWall;
    return;
  }
}

void add_pole(Scene& s, Layout& layout, Rng& rng, const std::vector<Vec2>& path, double d_min, double d_max) {
  for (int attempt = 0; attempt < 40; ++attempt) {
    const Vec2 c = beside_path(rng, path, d_min, d_max, nullptr);
    const double r = rng.uniform(0.08, 0.2);
    if (!layout.free(c, 0.0, r, r, 4.5)) continue;
    layout.take(c, 0.0, r, r);
    const double zg = s.ground.z_at(c.x(), c.y());
    s.cylinders.push_back({c, zg - 1.0, zg + rng.uniform(3.0, 9.0), r, static_cast<float>(rng.uniform(0.4, 0.8))});
    return;
  }
}

void add_car(Scene& s, Layout& layout, Rng& rng, const std::vector<Vec2>& path) {
  for (int attempt = 0; attempt < 40; ++attempt) {
    double h = 0.0;
    const Vec2 c = beside_path(rng, path, 5.5, 12.0, &h);
    const double yaw = h + (rng.uniform() < 0.5 ? 0.0 : kPi) + rng.normal(0.05);
    const double len = rng.uniform(4.0, 4.9), wid = rng.uniform(1.7, 1.95);
    if (!layout.free(c, yaw, len / 2, wid / 2, 5.0)) continue;
    layout.take(c, yaw, len / 2, wid / 2);
    const float refl = static_cast<float>(rng.uniform(0.2, 0.9));
    s.boxes.push_back(ground_box(s.ground, c, yaw, len, wid, 0.75, 0.25, refl));
    s.boxes.back().kind = BoxKind::kCar;
    const Vec2 cabin = c + Vec2(std::cos(yaw), std::sin(yaw)) * rng.uniform(-0.4, 0.2);
    s.boxes.push_back(ground_box(s.ground, cabin, yaw, len * 0.55, wid * 0.85, 0.5, 1.0, refl));
    s.boxes.back().kind = BoxKind::kCar;
    return;
  }
}

// Trees and bushes: clusters of jittered spheres, the non-planar clutter.
void add_vegetation(Scene& s, Layout& layout, Rng& rng, const std::vector<Vec2>& path, bool tree) {
  for (int attempt = 0; attempt < 40; ++attempt) {
    const Vec2 c = beside_path(rng, path, tree ? 7.0 : 5.0, 20.0, nullptr);
    const double spread = tree ? rng.uniform(1.5, 3.0) : rng.uniform(0.6, 1.5);
    if (!layout.free(c, 0.0, spread, spread, kCorridorM + 1.0)) continue;
    layout.take(c, 0.0, spread * 0.5, spread * 0.5);
    const double zg = s.ground.z_at(c.x(), c.y());
    double base = zg + rng.uniform(0.2, 0.6);
    if (tree) {
      const double trunk_h = rng.uniform(2.2, 3.5);
      s.cylinders.push_back({c, zg - 1.0, zg + trunk_h + 0.5, rng.uniform(0.12, 0.3), 0.35f});
      base = zg + trunk_h + spread * 0.6;
    }
    const int blobs = tree ? rng.uniform_int(12, 30) : rng.uniform_int(4, 10);
    for (int k = 0; k < blobs; ++k) {
      const Vec3 off(rng.normal(spread * 0.45), rng.normal(spread * 0.45), rng.normal(spread * (tree ? 0.35 : 0.2)));
      const double r = tree ? rng.uniform(0.4, 1.2) : rng.uniform(0.3, 0.7);
      Vec3 center(c.x() + off.x(), c.y() + off.y(), base + off.z());
      if (!tree) center.z() = std::max(center.z(), zg + 0.1);
      s.spheres.push_back({center, r, static_cast<float>(rng.uniform(0.2, 0.45))});
    }
    return;
  }
}

// Curbs along the path edges wherever they stay clear of the corridor.
void add_curbs(Scene& s, Layout& layout, Rng& rng, const std::vector<Vec2>& path, double offset_m) {
  const double seg = 3.0;
  double walked = 1e9;
  for (std::size_t i = 1; i < path.size(); ++i) {
    walked += (path[i] - path[i - 1]).norm();
    if (walked < seg) continue;
    walked = 0.0;
    const double h = path_heading(path, i);
    const Vec2 n(-std::sin(h), std::cos(h));
    for (double side : {-1.0, 1.0}) {
      const Vec2 c = path[i] + side * offset_m * n;
      if (!layout.free(c, h, seg / 2, 0.15, offset_m - 0.3, 0.0)) continue;
      layout.take(c, h, seg / 2, 0.15);
      s.boxes.push_back(ground_box(s.ground, c, h, seg, 0.3, 0.15, 0.0, 0.45f));
      s.boxes.back().kind = BoxKind::kCurb;
    }
  }
  (void)rng;
}

void add_lane_markings(Scene& s, const std::vector<Vec2>& path, double edge_offset_m) {
  // Dashed centre line (3 m dash, 3 m gap) and continuous edge lines, as short rectangles.
  double walked = 0.0;
  for (std::size_t i = 1; i < path.size(); ++i) {
    const double step = (path[i] - path[i - 1]).norm();
    walked += step;
    if (step < 1e-9) continue;
    const double h = path_heading(path, i);
    const Vec2 n(-std::sin(h), std::cos(h));
    if (std::fmod(walked, 6.0) < 3.0) s.markings.push_back({path[i], h, 0.5 * step + 0.02, 0.075});
    for (double side : {-1.0, 1.0}) s.markings.push_back({path[i] + side * edge_offset_m * n, h, 0.5 * step + 0.02, 0.1});
  }
}

}  // namespace

Scene make_scene(SceneKind kind, std::uint64_t seed, const std::vector<Vec2>& path_xy, const GroundPlane& ground,
                 double density) {
  auto count = [density](int n) { return static_cast<int>(std::lround(n * std::max(1.0, density))); };
  Scene s;
  s.ground = ground;
  std::vector<Vec2> path = path_xy;
  if (path.empty()) path.push_back(Vec2::Zero());
  if (path.size() == 1) path.push_back(path.front() + Vec2(0.01, 0.0));
  Rng rng(hash_counters(seed, 0x5CE4E));
  Layout layout(path, kCorridorM, 60.0);
  const double street_yaw = rng.uniform(-kPi, kPi);
  // Subsample the path for the markings (one every 0.5 m).
  std::vector<Vec2> sparse{path.front()};
  for (const Vec2& p : path)
    if ((p - sparse.back()).norm() >= 0.5) sparse.push_back(p);
  const std::vector<Vec2>& first_loop = sparse;  // the caller passes one loop of a repeated drive

  if (kind == SceneKind::kIntersection) {
    add_curbs(s, layout, rng, first_loop, 4.5);
    const int buildings = count(rng.uniform_int(10, 16));
    for (int i = 0; i < buildings; ++i) add_building(s, layout, rng, first_loop, street_yaw);
    for (int i = 0, n = count(rng.uniform_int(4, 8)); i < n; ++i) add_wall(s, layout, rng, first_loop, 6.0, 20.0);
    for (int i = 0, n = count(rng.uniform_int(10, 20)); i < n; ++i) add_pole(s, layout, rng, first_loop, 4.8, 15.0);
    for (int i = 0, n = count(rng.uniform_int(6, 12)); i < n; ++i) add_car(s, layout, rng, first_loop);
    for (int i = 0, n = count(rng.uniform_int(8, 14)); i < n; ++i) add_vegetation(s, layout, rng, first_loop, true);
    for (int i = 0, n = count(rng.uniform_int(6, 12)); i < n; ++i) add_vegetation(s, layout, rng, first_loop, false);
    add_lane_markings(s, first_loop, 3.2);
  } else {
    // Open lot: a couple of distant walls, a few poles and cars, parking lines.
    for (int i = 0, n = count(rng.uniform_int(2, 3)); i < n; ++i) add_wall(s, layout, rng, first_loop, 15.0, 35.0);
    for (int i = 0, n = count(rng.uniform_int(3, 5)); i < n; ++i) add_pole(s, layout, rng, first_loop, 6.0, 25.0);
    for (int i = 0, n = count(rng.uniform_int(1, 3)); i < n; ++i) add_car(s, layout, rng, first_loop);
    add_lane_markings(s, first_loop, 3.2);
  }
  s.finalize();
  return s;
}

}  // namespace insalign::sim
