#include "core/trajectory_correction.hpp"

#include <tbb/blocked_range.h>
#include <tbb/combinable.h>
#include <tbb/parallel_for.h>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <fmt/format.h>
#include <limits>

#include "core/deskew.hpp"
#include "core/occupancy.hpp"

namespace insalign {
namespace {

using Clock = std::chrono::steady_clock;
using MatX = Eigen::MatrixXd;
using VecX = Eigen::VectorXd;

// Parameters: tx ty tz (m), rotation about the INS axes (rad, R' = exp(w) R), time offset (s),
// then 3 position corrections per knot (m, world), then one heading correction per knot (rad).
constexpr int kExtrinsic = 7;
constexpr int kOffset = 6;
constexpr std::size_t kMinFrames = 10;
constexpr std::size_t kMaxKnots = 300;  // the normal equations are dense in the knots
constexpr double kLook_s = 0.006;       // the time-offset derivative looks this far beyond a sweep
constexpr std::uint32_t kAhead = 16;    // map points prefetched this far ahead
// Gauge: the corrections' mean is unobservable (a world shift; a heading mean is extrinsic yaw).
// A prior on the mean alone fixes it without pulling any knot towards zero. Pinned hard: the
// map's cost depends a little on where the voxel grid cuts it, and a 1 cm prior let that walk the
// whole trajectory 0.73 m (stage 3 then measured tz against the fiducials 0.73 m off).
constexpr double kMeanSigmaM = 1e-5;
constexpr double kMeanSigmaRad = 1e-4;

struct Layout {
  int knots = 0;
  bool heading = false;
  int size() const { return kExtrinsic + knots * (heading ? 4 : 3); }
  int pos(int k, int axis) const { return kExtrinsic + 3 * k + axis; }
  int head(int k) const { return kExtrinsic + 3 * knots + k; }
};

// Linear interpolation between knots: value = (1 - w) x[i] + w x[i + 1].
struct Hat {
  int i = 0;
  double w = 0.0;
};
Hat hat_at(const std::vector<double>& t_knots, double t_s) {
  const int n = static_cast<int>(t_knots.size());
  if (n < 2) return {};
  const double h = t_knots[1] - t_knots[0];
  const double f = (t_s - t_knots[0]) / h;
  const int i = std::clamp(static_cast<int>(std::floor(f)), 0, n - 2);
  return {i, std::clamp(f - i, 0.0, 1.0)};
}

// The sweeps and where their points sit in one map.
struct Problem {
  std::vector<Sweep> sweeps;
  std::vector<std::size_t> first;  // sweeps[f] holds map points [first[f], first[f + 1])
  std::vector<std::uint32_t> frame_of;
  std::size_t points() const { return first.back(); }
};
Problem make_problem(std::vector<Sweep> sweeps) {
  Problem p;
  p.sweeps = std::move(sweeps);
  p.first.assign(1, 0);
  for (const Sweep& s : p.sweeps) p.first.push_back(p.first.back() + s.size());
  p.frame_of.resize(p.points());
  for (std::size_t f = 0; f < p.sweeps.size(); ++f)
    std::fill(p.frame_of.begin() + p.first[f], p.frame_of.begin() + p.first[f + 1], static_cast<std::uint32_t>(f));
  return p;
}

void place_all(const Problem& p, const PoseStream& poses, const Iso3& T_ins_lidar, double offset_s,
               std::vector<Vec3f>& p_world) {
  p_world.resize(p.points());
  PlaceOptions options;
  options.time_offset_s = offset_s;
  tbb::parallel_for(std::size_t{0}, p.sweeps.size(), [&](std::size_t f) {
    const std::vector<Vec3f> w = sweep_to_world(p.sweeps[f], poses, T_ins_lidar, options);
    std::copy(w.begin(), w.end(), p_world.begin() + static_cast<std::ptrdiff_t>(p.first[f]));
  });
}

// Re-fits the planes of a frozen point grouping to the current map (centroid and normal).
void refit_planes(const std::vector<Vec3f>& p_world, LocalPlanes& lp) {
  tbb::parallel_for(std::size_t{0}, lp.planes.size(), [&](std::size_t k) {
    LocalPlane& plane = lp.planes[k];
    const Vec3 origin = p_world[lp.point_index[plane.first]].cast<double>();
    Vec3 sum = Vec3::Zero();
    Mat3 sum2 = Mat3::Zero();
    for (std::uint32_t m = plane.first; m < plane.first + plane.count; ++m) {
      const Vec3 d = p_world[lp.point_index[m]].cast<double>() - origin;
      sum += d;
      sum2 += d * d.transpose();
    }
    const Vec3 mean = sum / plane.count;
    Eigen::SelfAdjointEigenSolver<Mat3> es(sum2 / plane.count - mean * mean.transpose());
    plane.centroid = origin + mean;
    plane.normal = es.eigenvectors().col(0);
  });
}

struct Normal {
  MatX H;  // upper triangle filled during accumulation
  VecX g;
  double cost = 0.0, sq = 0.0;
  std::size_t n = 0;
  explicit Normal(int size) : H(MatX::Zero(size, size)), g(VecX::Zero(size)) {}
};

// One point's Jacobian row: at most 7 extrinsic + 2 knots x 4 entries.
struct SparseRow {
  int n = 0;
  std::array<int, 15> index{};
  std::array<double, 15> value{};
  void add(int i, double v) {
    index[n] = i;
    value[n++] = v;
  }
};

using VecE = Eigen::Matrix<double, kExtrinsic, 1>;
using MatE = Eigen::Matrix<double, kExtrinsic, kExtrinsic>;

// Scratch for one plane's summed Jacobian (the plane offset is eliminated per plane).
struct PlaneSum {
  VecX sum;
  std::vector<char> seen;
  std::vector<int> touched;
  std::vector<std::pair<int, int>> runs;  // [begin, end) of touched indices
  explicit PlaneSum(int size) : sum(VecX::Zero(size)), seen(static_cast<std::size_t>(size), 0) {}
  void add(int i, double v) {
    if (!seen[static_cast<std::size_t>(i)]) {
      seen[static_cast<std::size_t>(i)] = 1;
      touched.push_back(i);
    }
    sum[i] += v;
  }
  void add(const SparseRow& row, double w) {
    for (int a = 0; a < row.n; ++a) add(row.index[a], w * row.value[a]);
  }
  // Column by column over the touched indices' contiguous runs (neighbouring knots are neighbours
  // in H): one vectorised column segment per run instead of one scattered entry at a time, which
  // was two thirds of the correction's normal equations (a plane seen over a minute touches ~60
  // knots).
  void eliminate(MatX& H, double sum_w) {
    if (!std::is_sorted(touched.begin(), touched.end())) std::sort(touched.begin(), touched.end());
    runs.clear();
    for (int i : touched) {
      if (!runs.empty() && runs.back().second == i) {
        ++runs.back().second;
      } else {
        runs.push_back({i, i + 1});
      }
    }
    for (int b : touched) {
      const double f = sum[b] / sum_w;
      for (const auto& [lo, hi] : runs) {
        if (lo > b) break;
        const int n = std::min(hi, b + 1) - lo;
        H.col(b).segment(lo, n) -= f * sum.segment(lo, n);
      }
    }
    for (int a : touched) {
      sum[a] = 0.0;
      seen[static_cast<std::size_t>(a)] = 0;
    }
    touched.clear();
  }
};

// Without heading knots a point's row is [e (the 7 extrinsic and offset entries), (1 - w) n at
// knot k, w n at knot k + 1], n its plane's normal. The products of the points of one plane
// between the same two knots therefore need only sum((1 - w) e), sum(w e) and a few sums of
// scalars, added to H, g and the plane's summed row once per such run of points (sum(e e^T) needs
// no knot at all): per point a handful of fixed-size sums instead of a 13-entry sparse row
// scattered three times (with the prefetch: the correction's normal equations 0.73 -> 0.36 s of
// CPU on bench/correction_speed.sh's drive, bench/results/speed.md).
struct KnotRun {
  int k = -1;  // the run's first knot; -1: empty
  VecE e0 = VecE::Zero(), e1 = VecE::Zero();
  double s00 = 0.0, s01 = 0.0, s11 = 0.0, g0 = 0.0, g1 = 0.0;

  void add(const VecE& e, const Hat& h, double w, double res) {
    const double w0 = w * (1.0 - h.w), w1 = w * h.w;
    e0 += w0 * e;
    e1 += w1 * e;
    s00 += w0 * (1.0 - h.w);
    s01 += w0 * h.w;
    s11 += w1 * h.w;
    g0 += w0 * res;
    g1 += w1 * res;
  }
  void flush(const Vec3& n, const Layout& layout, MatX& H, VecX& g, PlaneSum& plane_sum) {
    if (k < 0) return;
    const int p0 = layout.pos(k, 0), p1 = layout.pos(k + 1, 0);
    H.block<kExtrinsic, 3>(0, p0) += e0 * n.transpose();
    H.block<kExtrinsic, 3>(0, p1) += e1 * n.transpose();
    const Mat3 nn = n * n.transpose();
    H.block<3, 3>(p0, p0).triangularView<Eigen::Upper>() += s00 * nn;
    H.block<3, 3>(p0, p1) += s01 * nn;
    H.block<3, 3>(p1, p1).triangularView<Eigen::Upper>() += s11 * nn;
    g.segment<3>(p0) += g0 * n;
    g.segment<3>(p1) += g1 * n;
    for (int i = 0; i < 3; ++i) {  // the summed row's knot entries: sum(w (1 - w_k)) n and sum(w w_k) n
      plane_sum.add(p0 + i, (s00 + s01) * n[i]);
      plane_sum.add(p1 + i, (s01 + s11) * n[i]);
    }
    *this = KnotRun{};
  }
};

// What the normal equations read of a plane's point that no iteration changes, in the planes'
// member order: read through point_index, the sweeps' scattered arrays made the sums wait on
// memory (one cache miss per array per point).
struct Member {
  Vec3f p_lidar;
  float dt_s;
  std::uint32_t frame;
};
std::vector<Member> gather_members(const Problem& p, const LocalPlanes& lp) {
  std::vector<Member> members(lp.point_index.size());
  tbb::parallel_for(std::size_t{0}, members.size(), [&](std::size_t m) {
    const std::uint32_t idx = lp.point_index[m];
    const std::uint32_t f = p.frame_of[idx];
    const Sweep& sweep = p.sweeps[f];
    const std::size_t j = idx - p.first[f];
    members[m] = {sweep.p_lidar[j], sweep.has_time() ? sweep.dt_s[j] : 0.0f, f};
  });
  return members;
}

// The point-to-plane normal equations of the map at the state, every parameter included.
Normal data_normal_equations(const Problem& p, const PoseStream& poses, const TrajectoryCorrection& s,
                             const Layout& layout, double huber_m, const std::vector<Vec3f>& p_world,
                             const LocalPlanes& lp, const std::vector<Member>& members) {
  std::vector<SweepMotion> tables(p.sweeps.size());
  tbb::parallel_for(std::size_t{0}, p.sweeps.size(),
                    [&](std::size_t f) { tables[f] = sweep_motion(p.sweeps[f], poses, s.time_offset_s); });
  const Mat3 R_ins_lidar = s.T_ins_lidar.linear();
  const int size = layout.size();
  tbb::combinable<Normal> acc([size] { return Normal(size); });
  tbb::combinable<PlaneSum> sums([size] { return PlaneSum(size); });
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, lp.planes.size(), 64), [&](const auto& r) {
    Normal& ne = acc.local();
    PlaneSum& plane_sum = sums.local();
    MatE ee = MatE::Zero();  // sum(w e e^T) over the range: no knot in it
    for (std::size_t k = r.begin(); k < r.end(); ++k) {
      const LocalPlane& plane = lp.planes[k];
      double sum_w = 0.0;
      VecE sum_e = VecE::Zero(), g_e = VecE::Zero();
      KnotRun run;
      // The extrinsic entries first: a plane's knots come in time order, so its touched indices
      // are then sorted already.
      if (!layout.heading)
        for (int i = 0; i < kExtrinsic; ++i) plane_sum.add(i, 0.0);
      for (std::uint32_t m = plane.first; m < plane.first + plane.count; ++m) {
        // The map's points are read in plane order, scattered over the map: fetched ahead.
        if (m + kAhead < lp.point_index.size()) __builtin_prefetch(&p_world[lp.point_index[m + kAhead]]);
        const Member& point = members[m];
        const double dt = point.dt_s;
        const SweepMotion& table = tables[point.frame];
        const std::size_t i_table = table.nearest(dt);
        const Vec3 q = p_world[lp.point_index[m]].cast<double>();
        const double res = plane.normal.dot(q - plane.centroid);
        const Vec3 a = R_ins_lidar * point.p_lidar.cast<double>();
        const Vec3 m_ins = table.R_world_ins[i_table].transpose() * plane.normal;
        const Vec3 arm = q - table.t_world_ins[i_table];
        VecE e;
        e << m_ins, a.cross(m_ins), plane.normal.dot(table.v_world[i_table] + table.w_world[i_table].cross(arm));
        const Hat h = hat_at(s.t_s, p.sweeps[point.frame].t_end_s + dt + s.time_offset_s);
        const double ar = std::abs(res);
        const double w = ar <= huber_m ? 1.0 : huber_m / ar;
        if (layout.heading) {
          SparseRow row;
          for (int i = 0; i < kExtrinsic; ++i) row.add(i, e[i]);
          for (int i = 0; i < 3; ++i) {
            row.add(layout.pos(h.i, i), (1.0 - h.w) * plane.normal[i]);
            row.add(layout.pos(h.i + 1, i), h.w * plane.normal[i]);
          }
          const double d_psi = plane.normal.dot(Vec3::UnitZ().cross(arm));
          row.add(layout.head(h.i), (1.0 - h.w) * d_psi);
          row.add(layout.head(h.i + 1), h.w * d_psi);
          for (int x = 0; x < row.n; ++x) ne.g[row.index[x]] += w * row.value[x] * res;
          for (int x = 0; x < row.n; ++x)
            for (int y = 0; y < row.n; ++y)
              if (row.index[x] <= row.index[y]) ne.H(row.index[x], row.index[y]) += w * row.value[x] * row.value[y];
          plane_sum.add(row, w);
        } else {
          if (h.i != run.k) {
            run.flush(plane.normal, layout, ne.H, ne.g, plane_sum);
            run.k = h.i;
          }
          run.add(e, h, w, res);
          ee.noalias() += (w * e) * e.transpose();  // fixed-size, inlined (rankUpdate was a call)
          sum_e += w * e;
          g_e += (w * res) * e;
        }
        sum_w += w;
        ne.cost += w * res * res;
        ne.sq += res * res;
        ++ne.n;
      }
      if (!layout.heading) {
        run.flush(plane.normal, layout, ne.H, ne.g, plane_sum);
        ne.g.head<kExtrinsic>() += g_e;
        for (int i = 0; i < kExtrinsic; ++i) plane_sum.add(i, sum_e[i]);
      }
      plane_sum.eliminate(ne.H, sum_w);
    }
    ne.H.topLeftCorner<kExtrinsic, kExtrinsic>().triangularView<Eigen::Upper>() += ee;
  });
  Normal total(size);
  acc.combine_each([&](const Normal& ne) {
    total.H += ne.H;
    total.g += ne.g;
    total.cost += ne.cost;
    total.sq += ne.sq;
    total.n += ne.n;
  });
  total.H = total.H.selfadjointView<Eigen::Upper>();
  return total;
}

// Prior variance of the change between knots k and k+1 per axis: the assumed random walk, or
// what the INS's stated variance does over the interval when that is more.
double stated_variance(const std::vector<InsQuality>& quality, double t_s, bool vertical) {
  if (quality.empty()) return 0.0;
  auto it = std::lower_bound(quality.begin(), quality.end(), t_s,
                             [](const InsQuality& q, double t) { return q.t_s < t; });
  if (it == quality.end()) --it;
  const double sd = vertical ? it->vertical_stddev_m : it->horizontal_stddev_m;
  return std::isfinite(sd) ? sd * sd : 0.0;
}

// Directions of the parameters along which the map does not change, only the knots do. The data
// say nothing along them but what the model gets wrong (attitude noise, plane fits, the knots'
// straight lines between poses), and that much, counted as information, decided the answer:
// - the map rotated about the world vertical by d is exactly an extrinsic yaw d plus the position
//   correction d z x p(t) (p the INS position) for a level car; letting the data decide moved yaw
//   0.057 deg on an RTK-fixed drive;
// - a horizontal lever-arm change l (INS frame) is exactly the position correction -R_world_ins(t) l;
//   letting the data decide put tx 20-120 mm off at a stated 4-7 mm on simulated drifting drives,
//   by 200 mm more or less with the frames picked (bench/results/honest.md).
// Their information is removed from the data term (H <- P H P, g <- P g, P projecting the modes
// out) and the random-walk prior alone decides how much of each the drift holds: the floor of
// bench/yaw_floor.py, which the stated stddev then is.
struct DataModes {
  std::vector<VecX> u;  // one vector per mode, over the whole parameter layout
};

DataModes data_modes(const Layout& layout, const std::vector<Iso3>& knot_T_world_ins, const RefineConfig& refine) {
  const int K = layout.knots;
  Vec3 centre = Vec3::Zero();
  for (const Iso3& T : knot_T_world_ins) centre += T.translation();
  centre /= static_cast<double>(std::max(1, K));
  DataModes modes;
  VecX yaw = VecX::Zero(layout.size());
  yaw[5] = 1.0;  // yaw of the extrinsic (about the INS vertical), rad
  for (int k = 0; k < K; ++k) {
    const Vec3 m = Vec3::UnitZ().cross(knot_T_world_ins[static_cast<std::size_t>(k)].translation() - centre);
    for (int i = 0; i < 3; ++i) yaw[layout.pos(k, i)] = m[i];
  }
  modes.u.push_back(std::move(yaw));
  for (int axis : {0, 1}) {
    if (refine.held[static_cast<std::size_t>(axis)]) continue;  // not a parameter: the knots alone are seen
    VecX u = VecX::Zero(layout.size());
    u[axis] = 1.0;
    for (int k = 0; k < K; ++k) {
      const Vec3 m = -(knot_T_world_ins[static_cast<std::size_t>(k)].linear().col(axis));
      for (int i = 0; i < 3; ++i) u[layout.pos(k, i)] = m[i];
    }
    modes.u.push_back(std::move(u));
  }
  return modes;
}

void remove_data_modes(const DataModes& modes, MatX& H, VecX& g) {
  // An orthonormal basis Q of the modes, then H <- (I - Q Q^T) H (I - Q Q^T).
  MatX U(H.rows(), static_cast<Eigen::Index>(modes.u.size()));
  for (std::size_t j = 0; j < modes.u.size(); ++j) U.col(static_cast<Eigen::Index>(j)) = modes.u[j];
  const Eigen::HouseholderQR<MatX> qr(U);
  const MatX Q = qr.householderQ() * MatX::Identity(U.rows(), U.cols());
  const MatX HQ = H * Q;
  const MatX QtHQ = Q.transpose() * HQ;
  H -= HQ * Q.transpose() + Q * HQ.transpose();
  H += Q * QtHQ * Q.transpose();
  g -= Q * (Q.transpose() * g);
}

// Adds the random-walk prior, the gauge and the fixed parameters (all in units of the data
// term scaled by 1/data_var) to the normal equations.
void add_priors(const TrajectoryCorrection& s, const Layout& layout, const TrajectoryCorrectionConfig& config,
                const std::vector<InsQuality>& quality, const RefineConfig& refine, MatX& H, VecX& g, double& prior_cost) {
  const int K = layout.knots;
  const double h = s.t_s.size() > 1 ? s.t_s[1] - s.t_s[0] : 1.0;
  const double q2 = config.drift_m_per_sqrt_s * config.drift_m_per_sqrt_s;
  for (int k = 0; k + 1 < K; ++k) {
    for (int axis = 0; axis < 3; ++axis) {
      const bool vertical = axis == 2;
      const double stated = std::abs(stated_variance(quality, s.t_s[k + 1], vertical) -
                                     stated_variance(quality, s.t_s[k], vertical));
      const double lambda = 1.0 / std::max({q2 * h, stated, 1e-12});
      const int a = layout.pos(k, axis), b = layout.pos(k + 1, axis);
      const double d = s.position_m[k + 1][axis] - s.position_m[k][axis];
      H(a, a) += lambda, H(b, b) += lambda, H(a, b) -= lambda, H(b, a) -= lambda;
      g[a] -= lambda * d, g[b] += lambda * d;
      prior_cost += lambda * d * d;
    }
    if (layout.heading) {
      const double sd = config.heading_drift_deg_per_sqrt_s * kRadPerDeg;
      const double lambda = 1.0 / std::max(sd * sd * h, 1e-16);
      const int a = layout.head(k), b = layout.head(k + 1);
      const double d = s.heading_rad[k + 1] - s.heading_rad[k];
      H(a, a) += lambda, H(b, b) += lambda, H(a, b) -= lambda, H(b, a) -= lambda;
      g[a] -= lambda * d, g[b] += lambda * d;
      prior_cost += lambda * d * d;
    }
  }
  // The mean of each correction series: lambda (sum x / K)^2.
  auto gauge = [&](auto index_of, auto value_of, double sigma) {
    const double lambda = 1.0 / (sigma * sigma * K * K);
    double sum = 0.0;
    for (int k = 0; k < K; ++k) sum += value_of(k);
    for (int a = 0; a < K; ++a) {
      g[index_of(a)] += lambda * sum;
      for (int b = 0; b < K; ++b) H(index_of(a), index_of(b)) += lambda;
    }
  };
  for (int axis = 0; axis < 3; ++axis)
    gauge([&](int k) { return layout.pos(k, axis); }, [&](int k) { return s.position_m[k][axis]; }, kMeanSigmaM);
  if (layout.heading) gauge([&](int k) { return layout.head(k); }, [&](int k) { return s.heading_rad[k]; }, kMeanSigmaRad);
  // tz stays where stage 3 put it (a vertical lever arm is a world shift here); the offset too
  // unless it is estimated, and the DOFs the pipeline holds.
  std::vector<int> fixed = {2};
  if (!refine.estimate_time_offset) fixed.push_back(kOffset);
  for (int i : {0, 1, 3, 4, 5})
    if (refine.held[static_cast<std::size_t>(i)]) fixed.push_back(i);
  for (int i : fixed) {
    H.row(i).setZero();
    H.col(i).setZero();
    H(i, i) = 1.0;
    g[i] = 0.0;
  }
}

void apply_step(TrajectoryCorrection& s, const Layout& layout, const VecX& dx) {
  Vec6 d6;
  d6 << dx.head<3>(), dx.segment<3>(3);
  s.T_ins_lidar = perturb_in_ins_frame(s.T_ins_lidar, d6);
  s.time_offset_s += dx[kOffset];
  for (int k = 0; k < layout.knots; ++k) {
    for (int axis = 0; axis < 3; ++axis) s.position_m[k][axis] += dx[layout.pos(k, axis)];
    if (layout.heading) s.heading_rad[k] += dx[layout.head(k)];
  }
}

// Knots over the INS times of the sweeps used, at least the configured spacing apart.
void place_knots(const Problem& p, double offset_s, const TrajectoryCorrectionConfig& config, TrajectoryCorrection& s) {
  double lo = 1e300, hi = -1e300;
  for (const Sweep& sweep : p.sweeps) {
    lo = std::min(lo, sweep.t_end_s + offset_s - 0.2);
    hi = std::max(hi, sweep.t_end_s + offset_s + kLook_s);
  }
  const double span = std::max(hi - lo, 1e-3);
  const double h = std::max(config.knot_spacing_s, span / static_cast<double>(kMaxKnots - 1));
  const int n = std::max(2, static_cast<int>(std::ceil(span / h)) + 1);
  for (int k = 0; k < n; ++k) s.t_s.push_back(lo + k * h);
  s.position_m.assign(s.t_s.size(), Vec3::Zero());
  if (config.estimate_heading) s.heading_rad.assign(s.t_s.size(), 0.0);
}

// Per world axis: RMS over the frames of the correction minus its mean (what it moves the map by).
Vec3 correction_rms_axes(const Problem& p, const TrajectoryCorrection& s) {
  std::vector<Vec3> c;
  for (const Sweep& sweep : p.sweeps) c.push_back(s.position_at(sweep.t_end_s + s.time_offset_s));
  const double n = static_cast<double>(std::max<std::size_t>(1, c.size()));
  Vec3 mean = Vec3::Zero();
  for (const Vec3& v : c) mean += v;
  mean /= n;
  Vec3 sum = Vec3::Zero();
  for (const Vec3& v : c) sum += (v - mean).cwiseAbs2();
  return (sum / n).cwiseSqrt();
}

struct Solver {
  const Problem& p;
  const FrameStore& store;
  const TrajectoryCorrectionConfig& config;
  const RefineConfig& refine;
  Layout layout;
  MatX H_last;  // the last system, priors included (for the covariance)

  // Gauss-Newton from s; returns false when too few points lie on planes.
  bool run(TrajectoryCorrection& s) {
    std::vector<Vec3f> p_world;
    LocalPlanes planes;
    std::vector<Member> members;
    const PlaneThicknessConfig pc = plane_thickness_config(refine);
    std::vector<Iso3> knot_T_world_ins;
    for (double t : s.t_s)
      knot_T_world_ins.push_back(store.poses().T_world_ins(std::clamp(t, store.poses().t_begin(), store.poses().t_end())));
    const DataModes modes = data_modes(layout, knot_T_world_ins, refine);
    for (int it = 0; it < config.max_iterations; ++it) {
      const PoseStream poses = corrected_poses(store.poses(), s);
      place_all(p, poses, s.T_ins_lidar, s.time_offset_s, p_world);
      if (it < config.refit_iterations || planes.planes.empty()) {
        planes = fit_local_planes(p_world, pc);
        members = gather_members(p, planes);
      } else {
        refit_planes(p_world, planes);
      }
      Normal ne = data_normal_equations(p, poses, s, layout, refine.huber_m, p_world, planes, members);
      if (ne.n < 100) return false;
      // The data term in units of its own noise, counted as point_correlation times fewer points.
      const double data_var = config.point_correlation * ne.cost / static_cast<double>(ne.n);
      ne.H /= data_var;
      ne.g /= data_var;
      double prior_cost = 0.0;
      remove_data_modes(modes, ne.H, ne.g);
      add_priors(s, layout, config, store.data().ins_quality, refine, ne.H, ne.g, prior_cost);
      VecX dx = ne.H.ldlt().solve(-ne.g);
      // Trust region: planes re-fitted from a smeared map only point the way for small steps.
      const double rot = dx.segment<3>(3).norm(), trans = dx.head<3>().norm();
      const double corr = dx.tail(dx.size() - kExtrinsic).cwiseAbs().maxCoeff();
      const double shrink = std::min({1.0, 0.5 * kRadPerDeg / std::max(rot, 1e-15), 0.05 / std::max(trans, 1e-15),
                                      0.01 / std::max(std::abs(dx[kOffset]), 1e-15), 0.1 / std::max(corr, 1e-15)});
      dx *= shrink;
      apply_step(s, layout, dx);
      s.iterations = it + 1;
      H_last = std::move(ne.H);
      if (rot < 1e-4 * kRadPerDeg && trans < 1e-5 && corr < 1e-4 && std::abs(dx[kOffset]) < 1e-5) break;
    }
    return true;
  }
};

double thickness_rms(const Problem& p, const PoseStream& poses, const TrajectoryCorrection& s, const RefineConfig& refine) {
  std::vector<Vec3f> p_world;
  place_all(p, poses, s.T_ins_lidar, s.time_offset_s, p_world);
  return plane_thickness(p_world, plane_thickness_config(refine)).rms_m;
}

}  // namespace

Vec3 prior_rms_axes_m(const TrajectoryCorrection& s, const TrajectoryCorrectionConfig& config,
                    const std::vector<InsQuality>& quality) {
  const double h = s.t_s.size() > 1 ? s.t_s[1] - s.t_s[0] : 1.0;
  const double q2 = config.drift_m_per_sqrt_s * config.drift_m_per_sqrt_s;
  Vec3 v = Vec3::Zero();
  for (std::size_t k = 0; k + 1 < s.t_s.size(); ++k)
    for (int axis = 0; axis < 3; ++axis) {
      const bool vertical = axis == 2;
      const double stated = std::abs(stated_variance(quality, s.t_s[k + 1], vertical) -
                                     stated_variance(quality, s.t_s[k], vertical));
      v[axis] += std::max(q2 * h, stated);
    }
  return (v / 6.0).cwiseSqrt();
}

void decide_application(const TrajectoryCorrectionConfig& config, TrajectoryCorrection& s, bool ins_states_drift) {
  const double gain = s.cost_ins_rms_m > 0.0 ? 1.0 - s.cost_corrected_rms_m / s.cost_ins_rms_m : 0.0;
  // The size threshold tells a drifting INS from an RTK-fixed one's noise (15 mm, 5-7% thinner);
  // an INS that states its drift has told already. Asked anyway, it refused corrections of
  // 24.5 mm that made the planes 20% thinner on 3 of 10 drifting drives (yaw 0.030 deg off
  // instead of 0.021, bench/results/honest.md).
  const bool big_enough = ins_states_drift || s.correction_rms_m >= config.apply_min_rms_m;
  const bool evidence = big_enough && gain >= config.apply_min_gain;
  int worst = 0;  // the axis furthest beyond its prior
  const Vec3 ratio = s.correction_rms_axes_m.cwiseQuotient(s.prior_rms_axes_m.cwiseMax(1e-9));
  ratio.maxCoeff(&worst);
  const bool plausible = ratio[worst] <= config.max_prior_ratio;
  s.applied = config.mode == TrajectoryCorrectionMode::kAlways || (evidence && plausible);
  const std::string implausible = fmt::format(
      "its {} part ({:.0f} mm RMS) is {:.0f}x what the INS's drift allows ({:.0f} mm): the LiDAR cannot correct the "
      "trajectory on this drive",
      std::array{"x", "y", "vertical"}[static_cast<std::size_t>(worst)], 1e3 * s.correction_rms_axes_m[worst],
      ratio[worst], 1e3 * s.prior_rms_axes_m[worst]);
  std::string why;
  if (s.applied) why = evidence && plausible ? "applied: the INS poses drift" : "applied (mode always)";
  else if (!evidence && ins_states_drift)
    why = fmt::format("not applied: the LiDAR does not confirm the drift the INS states (applies from {:.0f}% thinner)",
                      100.0 * config.apply_min_gain);
  else if (!evidence) why = fmt::format("not applied: the INS poses are consistent (auto applies from {:.0f} mm and {:.0f}%)",
                                        1e3 * config.apply_min_rms_m, 100.0 * config.apply_min_gain);
  else why = "not applied: " + implausible;
  s.decision = fmt::format(
      "the INS trajectory correction moves the frames by {:.1f} mm RMS and makes the map's planes {:.1f}% thinner "
      "({:.1f} -> {:.1f} mm); {}",
      1e3 * s.correction_rms_m, 100.0 * gain, 1e3 * s.cost_ins_rms_m, 1e3 * s.cost_corrected_rms_m, why);
}

double stated_drift_rms_m(const FrameStore& store) {
  double best = std::numeric_limits<double>::infinity(), sum_sq = 0.0;
  std::size_t n = 0;
  for (const InsQuality& q : store.data().ins_quality) {
    if (!std::isfinite(q.horizontal_stddev_m) || store.excluded(q.t_s, q.t_s)) continue;
    best = std::min(best, q.horizontal_stddev_m);
    sum_sq += q.horizontal_stddev_m * q.horizontal_stddev_m;
    ++n;
  }
  if (n == 0) return 0.0;
  return std::sqrt(std::max(0.0, sum_sq / static_cast<double>(n) - best * best));
}

double map_offset_median_m(const InsScreenResult& screen) {
  auto left_out = [&](double t_s) {
    return std::any_of(screen.spans.begin(), screen.spans.end(),
                       [t_s](const TimeSpan& span) { return t_s >= span.begin_s && t_s <= span.end_s; });
  };
  std::vector<double> offsets;
  for (const FrameOffset& o : screen.offsets)
    if (o.used && !o.flagged && !left_out(o.t_s)) offsets.push_back(o.residual_m);
  if (offsets.size() < 10) return std::numeric_limits<double>::quiet_NaN();
  const auto mid = offsets.begin() + static_cast<std::ptrdiff_t>(offsets.size() / 2);
  std::nth_element(offsets.begin(), mid, offsets.end());
  return *mid;
}

DriftEvidence drift_evidence(const FrameStore& store, const InsScreenResult& screen,
                             const TrajectoryCorrectionConfig& config) {
  DriftEvidence e;
  e.stated = std::any_of(store.data().ins_quality.begin(), store.data().ins_quality.end(),
                         [](const InsQuality& q) { return std::isfinite(q.horizontal_stddev_m); });
  if (e.stated) {
    e.value_m = stated_drift_rms_m(store);
    e.drifting = e.value_m >= config.drifting_min_stated_growth_m;
    e.message = fmt::format("the INS states {} (its stated horizontal stddev grows {:.1f} mm above its best; "
                            "if-drifting needs {:.0f} mm)", e.drifting ? "drift" : "no drift", 1e3 * e.value_m,
                            1e3 * config.drifting_min_stated_growth_m);
    return e;
  }
  const double median_m = map_offset_median_m(screen);
  e.measured = std::isfinite(median_m);
  if (!e.measured) {
    e.message = "the INS states no accuracy and the LiDAR check of the INS measured too few frames to tell whether it "
                "drifts";
    return e;
  }
  e.value_m = median_m;
  e.drifting = median_m >= config.drifting_min_map_offset_m;
  e.message = fmt::format("the INS states no accuracy; the frames sit {:.1f} mm (median) off the map of the drive's "
                          "other times, so it {} (if-drifting needs {:.0f} mm)", 1e3 * median_m,
                          e.drifting ? "drifts" : "does not drift", 1e3 * config.drifting_min_map_offset_m);
  return e;
}

Vec3 TrajectoryCorrection::position_at(double t) const {
  if (position_m.empty()) return Vec3::Zero();
  if (position_m.size() == 1) return position_m.front();
  const Hat h = hat_at(t_s, t);
  return (1.0 - h.w) * position_m[h.i] + h.w * position_m[h.i + 1];
}

double TrajectoryCorrection::heading_at(double t) const {
  if (heading_rad.size() < 2) return heading_rad.empty() ? 0.0 : heading_rad.front();
  const Hat h = hat_at(t_s, t);
  return (1.0 - h.w) * heading_rad[h.i] + h.w * heading_rad[h.i + 1];
}

PoseStream corrected_poses(const PoseStream& poses, const TrajectoryCorrection& c) {
  std::vector<StampedPose> out = poses.poses();
  for (StampedPose& pose : out) {
    pose.T_world_ins.translation() += c.position_at(pose.t_s);
    if (!c.heading_rad.empty())
      pose.T_world_ins.linear() = Eigen::AngleAxisd(c.heading_at(pose.t_s), Vec3::UnitZ()) * pose.T_world_ins.linear();
  }
  return PoseStream(std::move(out));
}

TrajectoryCorrection correct_trajectory(const FrameStore& store, const Iso3& T_ins_lidar_start,
                                        double time_offset_start_s, const TrajectoryCorrectionConfig& config,
                                        const RefineConfig& refine, const InsScreenResult* screen,
                                        const std::vector<std::size_t>& around) {
  const auto t0 = Clock::now();
  TrajectoryCorrection s;
  s.T_ins_lidar = T_ins_lidar_start;
  s.time_offset_s = time_offset_start_s;
  if (config.mode == TrajectoryCorrectionMode::kOff) {
    s.outcome.message = "INS trajectory correction off";
    return s;
  }
  bool ins_states_drift = false;
  if (config.mode == TrajectoryCorrectionMode::kIfDrifting) {
    const DriftEvidence evidence = drift_evidence(store, screen ? *screen : InsScreenResult{}, config);
    ins_states_drift = evidence.drifting && evidence.stated;
    if (!evidence.drifting) {
      s.outcome.message = "INS trajectory correction not needed: " + evidence.message;
      s.decision = s.outcome.message;
      return s;
    }
  }
  const double margin = refine_margin_s(refine);
  std::vector<std::size_t> frames;
  if (!around.empty()) {
    // Between stage 2's frames (slice centres), not at centres of slices of their own: the same
    // even spread, half of it decoded already (the correction 1.38 -> 1.2x the run without it).
    const std::size_t times = config.max_frames / around.size();  // at most max_frames in all
    frames = fill_between(drive_frames(store, time_offset_start_s, margin), around, times > 1 ? times - 1 : 0);
  } else {
    RefineConfig picking = refine;
    picking.max_frames = config.max_frames;
    frames = refine_frames(store, picking, time_offset_start_s, margin);
  }
  std::vector<Sweep> sweeps = store.thinned(frames, config.filter, /*keep_decoded=*/false);
  std::erase_if(sweeps, [&](const Sweep& sw) {
    return !sweep_covered(store.poses(), sw, time_offset_start_s, margin + kLook_s);
  });
  if (sweeps.size() < kMinFrames) {
    s.outcome.message = "INS trajectory correction skipped: fewer than 10 usable frames";
    return s;
  }
  const Problem p = make_problem(std::move(sweeps));
  s.frames_used = p.sweeps.size();
  s.points_used = p.points();
  place_knots(p, time_offset_start_s, config, s);
  Solver solver{p, store, config, refine, Layout{static_cast<int>(s.t_s.size()), config.estimate_heading}, {}};
  if (!solver.run(s)) {
    s = TrajectoryCorrection{};
    s.T_ins_lidar = T_ins_lidar_start;
    s.time_offset_s = time_offset_start_s;
    s.outcome.message = "INS trajectory correction skipped: fewer than 100 points on local planes";
    return s;
  }
  // Covariance of the extrinsic with the corrections marginalised.
  const MatX cov = solver.H_last.ldlt().solve(MatX::Identity(solver.H_last.rows(), solver.H_last.cols()));
  s.outcome.status = StageStatus::kOk;
  for (int i : {0, 1, 3, 4, 5}) {
    if (refine.held[static_cast<std::size_t>(i)]) continue;  // no stddev: not estimated
    s.outcome.stddev[i] = std::sqrt(std::max(0.0, cov(i, i)));
    s.outcome.determined[static_cast<std::size_t>(i)] = true;
  }
  s.time_offset_stddev_s = refine.estimate_time_offset ? std::sqrt(std::max(0.0, cov(kOffset, kOffset))) : 0.0;
  s.correction_rms_axes_m = correction_rms_axes(p, s);
  s.correction_rms_m = s.correction_rms_axes_m.norm();
  s.prior_rms_axes_m = prior_rms_axes_m(s, config, store.data().ins_quality);
  s.cost_corrected_rms_m = thickness_rms(p, corrected_poses(store.poses(), s), s, refine);
  s.cost_ins_rms_m = thickness_rms(p, store.poses(), s, refine);
  decide_application(config, s, ins_states_drift);
  s.outcome.wall_time_s = std::chrono::duration<double>(Clock::now() - t0).count();
  return s;
}

}  // namespace insalign
