#include "core/refine.hpp"

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

#include "core/deskew.hpp"
#include "core/occupancy.hpp"

namespace insalign {
namespace {

using Clock = std::chrono::steady_clock;
using Mat7 = Eigen::Matrix<double, 7, 7>;
using Vec7 = Eigen::Matrix<double, 7, 1>;

constexpr std::size_t kMinFrames = 10;
constexpr int kTimeIndex = 6;  // parameter order: x y z (m), rotation about INS x y z (rad), offset (s)

// A small change of the extrinsic and the offset. The rotation is applied on the INS side
// (R' = exp(omega) * R) so its components read as roll, pitch, yaw of the vehicle for any mount.
struct State {
  Iso3 T_ins_lidar = Iso3::Identity();
  double time_offset_s = 0.0;
};
State apply(const State& s, const Vec7& delta) {
  State out = s;
  out.T_ins_lidar.linear() = nearest_rotation(so3_exp(delta.segment<3>(3)) * s.T_ins_lidar.linear());
  out.T_ins_lidar.translation() += delta.head<3>();
  out.time_offset_s += delta(kTimeIndex);
  return out;
}

// The Jacobian's finite differences look this much beyond a sweep's time span.
constexpr double kJacobianLook_s = 0.006;

// Every LiDAR's part of a joint step (parameters [7 l, 7 l + 7) are LiDAR l's).
using States = std::vector<State>;
States apply_step(const States& s, const Eigen::VectorXd& delta) {
  States out = s;
  for (std::size_t l = 0; l < s.size(); ++l) out[l] = apply(s[l], delta.segment<kRefineParams>(kRefineParams * l));
  return out;
}

// The reduced frames of every LiDAR (LiDAR by LiDAR) and everything every evaluation needs.
struct Problem {
  std::vector<const PoseStream*> poses;  // per LiDAR
  std::vector<Sweep> frames;
  std::vector<std::uint16_t> lidar_of;   // per frame: its LiDAR
  std::vector<std::size_t> first;  // frames[f] occupies points [first[f], first[f+1]) of a map
  std::vector<std::uint16_t> frame_of;
  std::vector<bool> tz_free;       // per LiDAR: its tz estimated (a rig's relative heights)
  std::size_t lidars() const { return poses.size(); }
  std::size_t points() const { return first.back(); }
};

Problem make_problem(std::vector<const PoseStream*> poses, std::vector<Sweep> frames, std::vector<std::uint16_t> lidar_of) {
  Problem p;
  p.poses = std::move(poses);
  p.frames = std::move(frames);
  p.lidar_of = std::move(lidar_of);
  p.first.assign(1, 0);
  for (const Sweep& s : p.frames) p.first.push_back(p.first.back() + s.size());
  p.frame_of.resize(p.points());
  for (std::size_t f = 0; f < p.frames.size(); ++f) {
    std::fill(p.frame_of.begin() + p.first[f], p.frame_of.begin() + p.first[f + 1], static_cast<std::uint16_t>(f));
  }
  return p;
}

// The stitched map: every point deskewed through the INS poses at its own time, each frame
// through its LiDAR's extrinsic and offset.
void place_all(const Problem& p, const States& s, std::vector<Vec3f>& p_world) {
  p_world.resize(p.points());
  tbb::parallel_for(std::size_t{0}, p.frames.size(), [&](std::size_t f) {
    const std::size_t l = p.lidar_of[f];
    PlaceOptions options;
    options.time_offset_s = s[l].time_offset_s;
    const std::vector<Vec3f> w = sweep_to_world(p.frames[f], *p.poses[l], s[l].T_ins_lidar, options);
    std::copy(w.begin(), w.end(), p_world.begin() + static_cast<std::ptrdiff_t>(p.first[f]));
  });
}

double occupancy(const Problem& p, const States& s, double voxel_m, std::vector<Vec3f>& scratch) {
  place_all(p, s, scratch);
  return staggered_occupancy(scratch, voxel_m);
}

// Occupied voxels of each LiDAR's own part of the map (its frames are contiguous).
std::vector<std::size_t> occupied_per_lidar(const Problem& p, const States& s, double voxel_m) {
  std::vector<Vec3f> map;
  place_all(p, s, map);
  std::vector<std::size_t> out(p.lidars(), 0);
  for (std::size_t l = 0; l < p.lidars(); ++l) {
    std::size_t begin = p.points(), end = 0;
    for (std::size_t f = 0; f < p.frames.size(); ++f) {
      if (p.lidar_of[f] != l) continue;
      begin = std::min(begin, p.first[f]);
      end = std::max(end, p.first[f + 1]);
    }
    if (begin >= end) continue;
    if (begin == 0 && end == map.size()) {
      out[l] = count_occupied_voxels(map, voxel_m);
    } else {
      out[l] = count_occupied_voxels(std::vector<Vec3f>(map.begin() + static_cast<std::ptrdiff_t>(begin),
                                                        map.begin() + static_cast<std::ptrdiff_t>(end)),
                                     voxel_m);
    }
  }
  return out;
}

struct NormalEquations {
  std::size_t lidars = 1;
  std::vector<Mat7> H;    // lidars x lidars blocks, row-major; only a <= b kept (diagonal: upper triangle)
  std::vector<Vec7> g;    // per LiDAR
  double cost = 0.0;      // sum of robust-weighted squared distances
  double sq = 0.0;        // sum of squared distances (unweighted)
  std::size_t n = 0;
  std::vector<double> sq_lidar;      // per LiDAR: its points' squared distances
  std::vector<std::size_t> n_lidar;  // per LiDAR: its points on planes
  std::size_t shared_planes = 0;     // planes with points of more than one LiDAR
  explicit NormalEquations(std::size_t n_lidars = 1)
      : lidars(n_lidars), H(n_lidars * n_lidars, Mat7::Zero()), g(n_lidars, Vec7::Zero()), sq_lidar(n_lidars, 0.0),
        n_lidar(n_lidars, 0) {}
  Mat7& block(std::size_t a, std::size_t b) { return H[a * lidars + b]; }
  const Mat7& block(std::size_t a, std::size_t b) const { return H[a * lidars + b]; }
  NormalEquations& operator+=(const NormalEquations& o) {
    for (std::size_t i = 0; i < H.size(); ++i) H[i] += o.H[i];
    for (std::size_t l = 0; l < lidars; ++l) {
      g[l] += o.g[l];
      sq_lidar[l] += o.sq_lidar[l];
      n_lidar[l] += o.n_lidar[l];
    }
    cost += o.cost;
    sq += o.sq;
    n += o.n;
    shared_planes += o.shared_planes;
    return *this;
  }
  // The whole symmetric system over the 7N parameters.
  Eigen::MatrixXd hessian() const {
    Eigen::MatrixXd out(kRefineParams * lidars, kRefineParams * lidars);
    for (std::size_t a = 0; a < lidars; ++a) {
      out.block<kRefineParams, kRefineParams>(kRefineParams * a, kRefineParams * a) = block(a, a);
      for (std::size_t b = a + 1; b < lidars; ++b) {
        out.block<kRefineParams, kRefineParams>(kRefineParams * a, kRefineParams * b) = block(a, b);
        out.block<kRefineParams, kRefineParams>(kRefineParams * b, kRefineParams * a) = block(a, b).transpose();
      }
    }
    return out;
  }
  Eigen::VectorXd gradient() const {
    Eigen::VectorXd out(kRefineParams * lidars);
    for (std::size_t l = 0; l < lidars; ++l) out.segment<kRefineParams>(kRefineParams * l) = g[l];
    return out;
  }
};


// The stitched map's local planes and their points gathered in plane order: frame, LiDAR point
// and time once per grouping, world position every evaluation. The Jacobian loop then reads
// memory in sequence; gathering through point_index on every read missed the cache on four
// scattered arrays per point, most of the loop's time.
struct PlaneGrouping {
  LocalPlanes lp;                      // empty: fit them at the next evaluation
  std::vector<std::uint32_t> start;    // per plane: its first point in the arrays below
  std::vector<std::uint16_t> frame;
  std::vector<Vec3f> p_lidar, p_world;
  std::vector<float> dt_s;             // 0 for a sweep without point times
  bool empty() const { return lp.planes.empty(); }
  std::size_t planes() const { return lp.planes.size(); }
};

void gather_plane_points(const Problem& p, PlaneGrouping& g) {
  g.start.assign(1, 0);
  for (const LocalPlane& plane : g.lp.planes) g.start.push_back(g.start.back() + plane.count);
  const std::size_t n = g.start.back();
  g.frame.resize(n), g.p_lidar.resize(n), g.dt_s.resize(n), g.p_world.resize(n);
  tbb::parallel_for(std::size_t{0}, g.planes(), [&](std::size_t k) {
    const LocalPlane& plane = g.lp.planes[k];
    for (std::uint32_t i = 0; i < plane.count; ++i) {
      const std::uint32_t idx = g.lp.point_index[plane.first + i];
      const std::uint16_t f = p.frame_of[idx];
      const Sweep& sweep = p.frames[f];
      const std::size_t j = idx - p.first[f];
      g.frame[g.start[k] + i] = f;
      g.p_lidar[g.start[k] + i] = sweep.p_lidar[j];
      g.dt_s[g.start[k] + i] = sweep.has_time() ? sweep.dt_s[j] : 0.0f;
    }
  });
}

void gather_world(const std::vector<Vec3f>& p_world, PlaneGrouping& g) {
  tbb::parallel_for(std::size_t{0}, g.planes(), [&](std::size_t k) {
    const LocalPlane& plane = g.lp.planes[k];
    for (std::uint32_t i = 0; i < plane.count; ++i) g.p_world[g.start[k] + i] = p_world[g.lp.point_index[plane.first + i]];
  });
}

// Point-to-plane normal equations of the stitched map against its own local planes: at a fixed
// set of planes this is the gradient of the BALM smallest-eigenvalue cost.
// Re-fits the planes of a frozen point grouping to the current map (centroid and normal only).
void refit_planes(PlaneGrouping& g) {
  tbb::parallel_for(std::size_t{0}, g.planes(), [&](std::size_t k) {
    LocalPlane& plane = g.lp.planes[k];
    const Vec3f* q = g.p_world.data() + g.start[k];
    const Vec3 origin = q[0].cast<double>();
    Vec3 sum = Vec3::Zero();
    Mat3 sum2 = Mat3::Zero();
    for (std::uint32_t i = 0; i < plane.count; ++i) {
      const Vec3 d = q[i].cast<double>() - origin;
      sum += d;
      sum2 += d * d.transpose();
    }
    const Vec3 mean = sum / plane.count;
    Eigen::SelfAdjointEigenSolver<Mat3> es(sum2 / plane.count - mean * mean.transpose());
    plane.centroid = origin + mean;
    plane.normal = es.eigenvectors().col(0);
    plane.lambda_min = std::max(0.0, es.eigenvalues()(0));
  });
}

// d(point-to-plane residual) / d(the point's LiDAR's parameters), at knot kk of its frame.
Vec7 point_jacobian(const Vec3& normal, const SweepMotion& kn, std::size_t kk, const Mat3& R_ins_lidar, const Vec3f& p_lidar,
                    const Vec3& q_world) {
  const Vec3 a = R_ins_lidar * p_lidar.cast<double>();  // rotated point, INS axes
  const Vec3 m_ins = kn.R_world_ins[kk].transpose() * normal;
  Vec7 J;
  J.head<3>() = m_ins;
  J.segment<3>(3) = a.cross(m_ins);
  J(kTimeIndex) = normal.dot(kn.v_world[kk] + kn.w_world[kk].cross(q_world - kn.t_world_ins[kk]));
  return J;
}

double huber_weight(double residual_m, const RefineConfig& config) {
  const double ar = std::abs(residual_m);
  return ar <= config.huber_m ? 1.0 : config.huber_m / ar;
}

std::vector<SweepMotion> frame_knots(const Problem& p, const States& s) {
  std::vector<SweepMotion> knots(p.frames.size());
  tbb::parallel_for(std::size_t{0}, p.frames.size(), [&](std::size_t f) {
    knots[f] = sweep_motion(p.frames[f], *p.poses[p.lidar_of[f]], s[p.lidar_of[f]].time_offset_s);
  });
  return knots;
}

// One plane's sums per LiDAR present in it (a plane eliminates its offset over all its points,
// which is what ties one LiDAR's points to another's).
struct PlaneSums {
  std::vector<Mat7> JJ;
  std::vector<Vec7> J;
  std::vector<std::size_t> present;
  std::vector<char> seen;
  double w = 0.0;
  explicit PlaneSums(std::size_t lidars) : JJ(lidars), J(lidars), seen(lidars, 0) {}
  void start() {
    for (std::size_t l : present) seen[l] = 0;
    present.clear();
    w = 0.0;
  }
  void add(std::size_t l, const Vec7& j, double weight) {
    if (!seen[l]) {
      seen[l] = 1;
      present.push_back(l);
      JJ[l].setZero();
      J[l].setZero();
    }
    add_weighted_outer_upper(JJ[l], j, weight);
    J[l] += weight * j;
    w += weight;
  }
  // The plane moves with its points: eliminating its offset (the centroid) subtracts the
  // plane's mean Jacobian; without it every step is mostly absorbed by the re-fitted plane.
  void eliminate_into(NormalEquations& ne) {
    std::sort(present.begin(), present.end());
    for (std::size_t i = 0; i < present.size(); ++i) {
      const std::size_t a = present[i];
      ne.block(a, a) += JJ[a];
      ne.block(a, a).selfadjointView<Eigen::Upper>().rankUpdate(J[a], -1.0 / w);
      for (std::size_t k = i + 1; k < present.size(); ++k) ne.block(a, present[k]) -= J[a] * J[present[k]].transpose() / w;
    }
    if (present.size() > 1) ++ne.shared_planes;
  }
};

// g: the planes; empty = fit them from the current map, else keep its point grouping (a fixed
// grouping makes the cost smooth, so the last iterations converge instead of jittering as
// voxels flip in and out of the planar set).
NormalEquations build_normal_equations(const Problem& p, const States& s, const RefineConfig& config,
                                       std::vector<Vec3f>& p_world, PlaneGrouping& g) {
  place_all(p, s, p_world);
  const bool fit = g.empty();
  if (fit) {
    g.lp = fit_local_planes(p_world, plane_thickness_config(config));
    gather_plane_points(p, g);
  }
  gather_world(p_world, g);
  if (!fit) refit_planes(g);
  const std::vector<SweepMotion> knots = frame_knots(p, s);
  const std::size_t n_lidars = p.lidars();
  tbb::combinable<NormalEquations> acc([n_lidars] { return NormalEquations(n_lidars); });
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, g.planes(), 256), [&](const auto& r) {
    NormalEquations& ne = acc.local();
    PlaneSums sums(n_lidars);
    for (std::size_t k = r.begin(); k < r.end(); ++k) {
      const LocalPlane& plane = g.lp.planes[k];
      sums.start();
      for (std::uint32_t m = g.start[k]; m < g.start[k + 1]; ++m) {
        const std::size_t f = g.frame[m];
        const std::size_t l = p.lidar_of[f];
        const SweepMotion& kn = knots[f];
        const std::size_t kk = kn.nearest(g.dt_s[m]);
        const Vec3 q = g.p_world[m].cast<double>();
        const double res = plane.normal.dot(q - plane.centroid);
        const Vec7 J = point_jacobian(plane.normal, kn, kk, s[l].T_ins_lidar.linear(), g.p_lidar[m], q);
        const double w = huber_weight(res, config);
        sums.add(l, J, w);
        ne.g[l] += w * res * J;
        ne.cost += w * res * res;
        ne.sq += res * res;
        ++ne.n;
        ne.sq_lidar[l] += res * res;
        ++ne.n_lidar[l];
      }
      sums.eliminate_into(ne);
    }
  });
  NormalEquations total(n_lidars);
  acc.combine_each([&](const NormalEquations& ne) { total += ne; });
  for (std::size_t l = 0; l < n_lidars; ++l) total.block(l, l) = total.block(l, l).selfadjointView<Eigen::Upper>();
  return total;
}

// How stage 2's gradient moves when the INS misplaces frame f by e_f (world frame): g += G[f] e_f,
// G[f] 7N x 3. A plane's offset follows its points (as in PlaneSums::eliminate_into), so a shift
// common to every frame moves nothing: only what differs between frames counts.
std::vector<Eigen::MatrixX3d> frame_shift_sensitivity(const Problem& p, const States& s, const RefineConfig& config,
                                                      const PlaneGrouping& g) {
  const std::vector<SweepMotion> knots = frame_knots(p, s);
  const Eigen::Index n_all = kRefineParams * static_cast<Eigen::Index>(p.lidars());
  const auto zero = [&] { return std::vector<Eigen::MatrixX3d>(p.frames.size(), Eigen::MatrixX3d::Zero(n_all, 3)); };
  tbb::combinable<std::vector<Eigen::MatrixX3d>> acc(zero);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, g.planes(), 256), [&](const auto& r) {
    std::vector<Eigen::MatrixX3d>& G = acc.local();
    struct Part { std::size_t frame; Eigen::VectorXd wJ; double w; };
    std::vector<Part> parts;  // the plane's frames, in the order met
    for (std::size_t k = r.begin(); k < r.end(); ++k) {
      const LocalPlane& plane = g.lp.planes[k];
      parts.clear();
      Eigen::VectorXd wJ_all = Eigen::VectorXd::Zero(n_all);
      double w_all = 0.0;
      for (std::uint32_t m = g.start[k]; m < g.start[k + 1]; ++m) {
        const std::size_t f = g.frame[m];
        const std::size_t l = p.lidar_of[f];
        const SweepMotion& kn = knots[f];
        const Vec3 q = g.p_world[m].cast<double>();
        const double w = huber_weight(plane.normal.dot(q - plane.centroid), config);
        const Vec7 J = point_jacobian(plane.normal, kn, kn.nearest(g.dt_s[m]), s[l].T_ins_lidar.linear(),
                                      g.p_lidar[m], q);
        if (parts.empty() || parts.back().frame != f) {
          auto it = std::find_if(parts.begin(), parts.end(), [&](const Part& x) { return x.frame == f; });
          if (it == parts.end()) parts.push_back({f, Eigen::VectorXd::Zero(n_all), 0.0});
          else std::rotate(it, it + 1, parts.end());  // the frame met again goes last
        }
        const Eigen::Index at = kRefineParams * static_cast<Eigen::Index>(l);
        parts.back().wJ.segment(at, kRefineParams) += w * J;
        parts.back().w += w;
        wJ_all.segment(at, kRefineParams) += w * J;
        w_all += w;
      }
      if (w_all <= 0.0) continue;
      for (const Part& part : parts) G[part.frame] += (part.wJ - wJ_all * (part.w / w_all)) * plane.normal.transpose();
    }
  });
  std::vector<Eigen::MatrixX3d> out = zero();
  acc.combine_each([&](const std::vector<Eigen::MatrixX3d>& G) {
    for (std::size_t f = 0; f < out.size(); ++f) out[f] += G[f];
  });
  return out;
}

// S[f] = H^-1 G[f], 7N x 3 (rows of parameters not estimated zero): what frame f's INS position
// error moves the estimate by, to first order (dx = -sum_f S[f] e_f).
std::vector<Eigen::MatrixX3d> ins_shift(const std::vector<Eigen::MatrixX3d>& G, const Eigen::MatrixXd& H_active,
                                        const std::vector<int>& params) {
  const int n_dof = static_cast<int>(params.size());
  const Eigen::MatrixXd Hinv = H_active.ldlt().solve(Eigen::MatrixXd::Identity(n_dof, n_dof));
  std::vector<Eigen::MatrixX3d> S(G.size());
  Eigen::MatrixX3d G_active(n_dof, 3);
  for (std::size_t f = 0; f < G.size(); ++f) {
    for (int a = 0; a < n_dof; ++a) G_active.row(a) = G[f].row(params[a]);
    const Eigen::MatrixX3d s_active = Hinv * G_active;
    S[f] = Eigen::MatrixX3d::Zero(G[f].rows(), 3);
    for (int a = 0; a < n_dof; ++a) S[f].row(params[a]) = s_active.row(a);
  }
  return S;
}

// Covariance of the parameters from an INS position error that is exponentially correlated in
// time (sigmas per world axis, config.ins_slow_error_*).
Eigen::MatrixXd ins_position_covariance(const Problem& p, const std::vector<Eigen::MatrixX3d>& S,
                                        const RefineConfig& config) {
  const Vec3 var(config.ins_slow_error_horizontal_m * config.ins_slow_error_horizontal_m,
                 config.ins_slow_error_horizontal_m * config.ins_slow_error_horizontal_m,
                 config.ins_slow_error_vertical_m * config.ins_slow_error_vertical_m);
  const Eigen::Index n = S.empty() ? 0 : S.front().rows();
  Eigen::MatrixXd cov = Eigen::MatrixXd::Zero(n, n);
  const double tau = std::max(config.ins_slow_error_correlation_s, 1e-6);
  for (std::size_t f = 0; f < S.size(); ++f) {
    const Eigen::MatrixX3d SfV = S[f] * var.asDiagonal();
    for (std::size_t h = 0; h < S.size(); ++h) {
      const double rho = std::exp(-std::abs(p.frames[f].t_end_s - p.frames[h].t_end_s) / tau);
      cov.noalias() += rho * SfV * S[h].transpose();
    }
  }
  return cov;
}

std::vector<int> active_dofs(const RefineConfig& c, bool time_offset, bool tz) {
  std::vector<int> dofs;
  for (int d = 0; d < 6; ++d)
    if (!c.held[static_cast<std::size_t>(d)] && (d != 2 || c.estimate_tz || tz)) dofs.push_back(d);
  if (time_offset) dofs.push_back(kTimeIndex);
  return dofs;
}

// Indices into the 7N joint parameters.
std::vector<int> active_params(const RefineConfig& c, const std::vector<bool>& offset_free,
                               const std::vector<bool>& tz_free) {
  std::vector<int> out;
  for (std::size_t l = 0; l < offset_free.size(); ++l)
    for (int d : active_dofs(c, offset_free[l], tz_free[l])) out.push_back(kRefineParams * static_cast<int>(l) + d);
  return out;
}

std::string fmt_m(double v) { return fmt::format("{}", v); }

// What a search method finds besides the states.
struct Search {
  std::vector<std::vector<RefineRound>> rounds;  // per LiDAR
  int evaluations = 0;
  double crispness_before = 0.0, crispness_after = 0.0;
  std::string measure;
  bool converged = false;
  bool undetermined = false;
  std::string message;
  std::size_t planes = 0, shared_planes = 0;
  Eigen::MatrixXd information, covariance;  // 7N x 7N (continuous method)
  Eigen::MatrixXd ins_covariance;           // 7N x 7N: the INS's correlated position error's share
  std::vector<Eigen::MatrixX3d> ins_shift;  // per frame, 7N x 3 (see ins_shift())
  std::vector<double> frame_t_s;
  double sigma_m = 0.0;
  std::vector<double> residuals, rms_first_m, rms_last_m;  // per LiDAR
};

// ---- The paper's search: coordinate-wise grid search with shrinking steps on occupancy. ----
States grid_search(const Problem& p, const States& start, const std::vector<bool>& offset_free,
                   const RefineConfig& config, Search& out, const std::function<void(double)>& progress) {
  std::vector<Vec3f> scratch;
  States best = start;
  double best_cost = occupancy(p, best, config.occupancy_voxel_m, scratch);
  ++out.evaluations;
  out.crispness_before = best_cost;
  double scale = 1.0;
  for (int round = 0; round < config.grid_rounds; ++round) {
    for (int pass = 0; pass < config.grid_sweeps_per_round; ++pass) {
      for (std::size_t l = 0; l < p.lidars(); ++l) {
        const std::vector<int> dofs = active_dofs(config, offset_free[l], p.tz_free[l]);
        // Time offset first: it moves points the most; then rotations, then translations.
        std::vector<int> order;
        if (offset_free[l]) order.push_back(kTimeIndex);
        for (int d : {5, 3, 4, 0, 1, 2}) {
          if (std::find(dofs.begin(), dofs.end(), d) != dofs.end()) order.push_back(d);
        }
        for (int d : order) {
          const double range = scale * (d < 3 ? config.grid_trans_range_m
                                              : d < 6 ? config.grid_rot_range_deg * kRadPerDeg
                                                      : config.time_offset_range_s);
          const double step = range / std::max(1, config.grid_steps);
          const States centre = best;
          for (int i = -config.grid_steps; i <= config.grid_steps; ++i) {
            if (i == 0) continue;
            Vec7 delta = Vec7::Zero();
            delta(d) = i * step;
            States cand = centre;
            cand[l] = apply(centre[l], delta);
            if (d == kTimeIndex &&
                std::abs(cand[l].time_offset_s - start[l].time_offset_s) > config.time_offset_range_s + 1e-12) {
              continue;
            }
            const double cost = occupancy(p, cand, config.occupancy_voxel_m, scratch);
            ++out.evaluations;
            if (cost < best_cost) {
              best_cost = cost;
              best = cand;
            }
          }
        }
      }
    }
    for (std::size_t l = 0; l < p.lidars(); ++l)
      out.rounds[l].push_back({round, best[l].T_ins_lidar, best[l].time_offset_s, best_cost});
    if (progress) progress(0.1 + 0.9 * (round + 1) / config.grid_rounds);
    scale *= config.grid_shrink;
  }
  out.crispness_after = best_cost;
  out.measure = "occupied voxels (" + fmt_m(config.occupancy_voxel_m) + " m, mean of 2 staggered grids)";
  out.converged = true;
  return best;
}

// A wrong offset of tens of milliseconds smears the map by decimetres, beyond the reach of the
// local planes; a coarse occupancy scan of LiDAR l's own frames puts Gauss-Newton within a step
// of the optimum.
double scan_time_offset(const Problem& p, std::size_t l, const State& start, const RefineConfig& config,
                        Search& out, std::vector<Vec3f>& scratch) {
  const int n = static_cast<int>(std::floor(config.time_offset_range_s / config.time_offset_scan_step_s + 1e-9));
  std::vector<std::size_t> own;
  for (std::size_t f = 0; f < p.frames.size(); ++f)
    if (p.lidar_of[f] == l) own.push_back(f);
  // Every few frames suffice for a decimetre-scale smear; the scan is then a small part of the stage.
  const std::size_t stride = (own.size() + 39) / 40;
  std::vector<Sweep> subset;
  for (std::size_t k = 0; k < own.size(); k += stride) subset.push_back(p.frames[own[k]]);
  const std::size_t count = subset.size();
  const Problem coarse = make_problem({p.poses[l]}, std::move(subset), std::vector<std::uint16_t>(count, 0));
  double best_cost = 0.0;
  double best_offset = start.time_offset_s;
  for (int i = -n; i <= n; ++i) {
    State cand = start;
    cand.time_offset_s = start.time_offset_s + i * config.time_offset_scan_step_s;
    place_all(coarse, {cand}, scratch);
    const double cost = static_cast<double>(count_occupied_voxels(scratch, config.time_offset_scan_voxel_m));
    ++out.evaluations;
    if (i == -n || cost < best_cost) {
      best_cost = cost;
      best_offset = cand.time_offset_s;
    }
  }
  return best_offset;
}

// Trust region: planes re-fitted from a smeared map only point the way for small steps. One
// factor for the whole step keeps it a Gauss-Newton direction.
double step_shrink(const Eigen::VectorXd& delta, std::size_t lidars) {
  double shrink = 1.0;
  for (std::size_t l = 0; l < lidars; ++l) {
    const Vec7 d = delta.segment<kRefineParams>(kRefineParams * l);
    const double rot = d.segment<3>(3).norm(), trans = d.head<3>().norm();
    shrink = std::min({shrink, (0.5 * kRadPerDeg) / std::max(rot, 1e-15), 0.05 / std::max(trans, 1e-15),
                       0.01 / std::max(std::abs(d(kTimeIndex)), 1e-15)});
  }
  return shrink;
}

bool step_converged(const Eigen::VectorXd& delta, std::size_t lidars, const RefineConfig& config) {
  for (std::size_t l = 0; l < lidars; ++l) {
    const Vec7 d = delta.segment<kRefineParams>(kRefineParams * l);
    if (!(d.segment<3>(3).norm() < config.converged_rot_deg * kRadPerDeg && d.head<3>().norm() < config.converged_trans_m &&
          std::abs(d(kTimeIndex)) < 1e-5)) {
      return false;
    }
  }
  return true;
}

void record_rms(const NormalEquations& ne, std::vector<double>& rms_m) {
  rms_m.assign(ne.lidars, 0.0);
  for (std::size_t l = 0; l < ne.lidars; ++l)
    rms_m[l] = ne.n_lidar[l] > 0 ? std::sqrt(ne.sq_lidar[l] / static_cast<double>(ne.n_lidar[l])) : 0.0;
}

// ---- Smooth variant: plane thickness by Gauss-Newton, with a coarse offset scan first. ----
States gauss_newton(const Problem& p, const States& start, const std::vector<bool>& offset_free,
                    const RefineConfig& config, Search& out, const std::function<void(double)>& progress) {
  std::vector<Vec3f> scratch;
  States s = start;
  for (std::size_t l = 0; l < p.lidars(); ++l) {
    if (offset_free[l] && config.time_offset_scan_step_s > 0.0)
      s[l].time_offset_s = scan_time_offset(p, l, start[l], config, out, scratch);
  }
  const std::vector<int> params = active_params(config, offset_free, p.tz_free);
  const int n_dof = static_cast<int>(params.size());
  const int n_all = kRefineParams * static_cast<int>(p.lidars());
  Eigen::MatrixXd H_active;
  double sigma2 = 0.0;
  PlaneGrouping planes;
  for (int it = 0; it < config.max_iterations; ++it) {
    if (it < config.refit_iterations) planes = PlaneGrouping{};
    const NormalEquations ne = build_normal_equations(p, s, config, scratch, planes);
    ++out.evaluations;
    out.planes = planes.planes();
    out.shared_planes = ne.shared_planes;
    const double rms = ne.n > 0 ? std::sqrt(ne.sq / static_cast<double>(ne.n)) : 0.0;
    if (it == 0) {
      out.crispness_before = rms;
      record_rms(ne, out.rms_first_m);
    }
    out.crispness_after = rms;
    record_rms(ne, out.rms_last_m);
    if (ne.n < 100) {
      out.undetermined = true;
      out.message = "stage 2: fewer than 100 points on local planes in the stitched map";
      return start;
    }
    const Eigen::MatrixXd H = ne.hessian();
    const Eigen::VectorXd g = ne.gradient();
    H_active.resize(n_dof, n_dof);
    Eigen::VectorXd g_active(n_dof);
    for (int a = 0; a < n_dof; ++a) {
      g_active(a) = g(params[a]);
      for (int b = 0; b < n_dof; ++b) H_active(a, b) = H(params[a], params[b]);
    }
    sigma2 = ne.cost / std::max<double>(1.0, static_cast<double>(ne.n) - n_dof);
    out.information = H;
    out.residuals.assign(ne.n_lidar.begin(), ne.n_lidar.end());
    Eigen::MatrixXd A = H_active;
    for (int a = 0; a < n_dof; ++a) A(a, a) += 1e-9 * H_active(a, a) + 1e-12;
    const Eigen::VectorXd dx = A.ldlt().solve(-g_active);
    Eigen::VectorXd delta = Eigen::VectorXd::Zero(n_all);
    for (int a = 0; a < n_dof; ++a) delta(params[a]) = dx(a);
    delta *= step_shrink(delta, p.lidars());
    s = apply_step(s, delta);
    for (std::size_t l = 0; l < p.lidars(); ++l) out.rounds[l].push_back({it, s[l].T_ins_lidar, s[l].time_offset_s, rms});
    if (progress) progress(0.1 + 0.9 * (it + 1) / config.max_iterations);
    if (step_converged(delta, p.lidars(), config)) {
      out.converged = true;
      break;
    }
  }
  // 1-sigma from the information of the last iteration (points treated as independent, which
  // makes this optimistic; a guide to which DOF the drive pins down, not a guarantee).
  const Eigen::MatrixXd cov = sigma2 * H_active.ldlt().solve(Eigen::MatrixXd::Identity(n_dof, n_dof));
  out.covariance = Eigen::MatrixXd::Zero(n_all, n_all);
  for (int a = 0; a < n_dof; ++a)
    for (int b = 0; b < n_dof; ++b) out.covariance(params[a], params[b]) = cov(a, b);
  if (!config.extrinsic_only && !planes.empty() && H_active.size() > 0) {
    out.ins_shift = ins_shift(frame_shift_sensitivity(p, s, config, planes), H_active, params);
    out.ins_covariance = ins_position_covariance(p, out.ins_shift, config);
    out.frame_t_s.clear();
    for (const auto& f : p.frames) out.frame_t_s.push_back(f.t_end_s);
  }
  out.sigma_m = std::sqrt(sigma2);
  out.measure = "plane thickness RMS (m, " + fmt_m(config.plane_voxel_m) + " m planes)";
  return s;
}

// Per-LiDAR stddev and verdicts from the joint covariance (estimated parameters only).
void set_stddevs(const Search& search, const std::vector<bool>& offset_free, const std::vector<bool>& tz_free,
                 const RefineConfig& config, std::vector<RefineResult>& results) {
  if (search.covariance.size() == 0) return;
  for (std::size_t l = 0; l < results.size(); ++l) {
    for (int d : active_dofs(config, offset_free[l], tz_free[l])) {
      const int i = kRefineParams * static_cast<int>(l) + d;
      const double sd = std::sqrt(std::max(0.0, search.covariance(i, i)));
      if (d == kTimeIndex) {
        results[l].time_offset_stddev_s = sd;
      } else {
        results[l].outcome.stddev(d) = sd;
        results[l].outcome.determined[static_cast<std::size_t>(d)] = true;
        if (search.ins_covariance.size() > 0)
          results[l].ins_position_stddev(d) = std::sqrt(std::max(0.0, search.ins_covariance(i, i)));
      }
    }
    results[l].ins_shift_t_s = search.frame_t_s;
    results[l].ins_shift.clear();
    for (const Eigen::MatrixX3d& S : search.ins_shift)
      results[l].ins_shift.push_back(S.middleRows<kRefineParams>(kRefineParams * static_cast<Eigen::Index>(l)));
  }
}

// The LiDARs' frames thinned into one problem (LiDAR by LiDAR); `covered`: only sweeps the
// poses cover through the start offset (with the offset search's margin).
Problem joint_problem(const std::vector<RefineLidar>& lidars, const RefineConfig& config,
                      const std::vector<bool>& offset_free, bool covered, std::vector<std::size_t>& frames_per_lidar,
                      std::vector<std::size_t>& points_per_lidar) {
  std::vector<const PoseStream*> poses;
  std::vector<Sweep> all;
  std::vector<std::uint16_t> lidar_of;
  for (std::size_t l = 0; l < lidars.size(); ++l) {
    const RefineLidar& in = lidars[l];
    const double margin = offset_free[l] ? config.time_offset_range_s : 0.0;
    SweepFilter filter = config.filter;
    if (in.max_points > 0 && (filter.max_points == 0 || in.max_points < filter.max_points)) filter.max_points = in.max_points;
    std::vector<Sweep> sweeps = in.store->thinned(in.frames, filter);
    if (covered) {
      std::erase_if(sweeps, [&](const Sweep& s) {
        return !sweep_covered(in.store->poses(), s, in.time_offset_start_s, margin + kJacobianLook_s);
      });
    }
    frames_per_lidar.push_back(sweeps.size());
    std::size_t points = 0;
    for (Sweep& sweep : sweeps) {
      points += sweep.size();
      all.push_back(std::move(sweep));
      lidar_of.push_back(static_cast<std::uint16_t>(l));
    }
    points_per_lidar.push_back(points);
    poses.push_back(&in.store->poses());
  }
  Problem p = make_problem(std::move(poses), std::move(all), std::move(lidar_of));
  for (const RefineLidar& in : lidars) p.tz_free.push_back(in.estimate_tz);
  return p;
}

std::vector<bool> offsets_free(const std::vector<RefineLidar>& lidars, const RefineConfig& config) {
  std::vector<bool> out;
  for (const RefineLidar& l : lidars) out.push_back(config.estimate_time_offset && l.estimate_time_offset);
  return out;
}

// Fills every LiDAR's result from the search.
void distribute(const Search& search, const States& final_states, JointRefineResult& result) {
  for (std::size_t l = 0; l < result.lidars.size(); ++l) {
    RefineResult& r = result.lidars[l];
    r.measure = search.measure;
    r.crispness_before = search.crispness_before;
    r.crispness_after = search.crispness_after;
    r.planes_used = search.planes;
    r.evaluations = search.evaluations;
    r.converged = search.converged;
    r.rounds = search.rounds[l];
    r.T_ins_lidar = final_states[l].T_ins_lidar;
    r.time_offset_s = final_states[l].time_offset_s;
    if (search.undetermined) {
      r.outcome.status = StageStatus::kUndetermined;
      r.outcome.message = search.message;
    }
  }
  result.information = search.information;
  result.covariance = search.covariance;
  result.residual_sigma_m = search.sigma_m;
  result.residuals = search.residuals;
  result.rms_before_m = search.rms_first_m;
  result.rms_after_m = search.rms_last_m;
  result.planes_used = search.planes;
  result.shared_planes = search.shared_planes;
  result.evaluations = search.evaluations;
  if (search.undetermined) {
    result.outcome.status = StageStatus::kUndetermined;
    result.outcome.message = search.message;
  }
}

std::string lidar_prefix(const RefineLidar& l) { return l.name.empty() ? "" : "LiDAR '" + l.name + "': "; }

}  // namespace

PlaneThicknessConfig plane_thickness_config(const RefineConfig& c) {
  PlaneThicknessConfig pc;
  pc.voxel_m = c.plane_voxel_m;
  pc.min_voxel_m = c.plane_voxel_min_m;
  pc.min_points = c.plane_min_points;
  pc.max_planarity = c.plane_max_planarity;
  return pc;
}

std::vector<std::size_t> refine_frames(const FrameStore& store, const RefineConfig& config, double time_offset_s,
                                       double margin_s) {
  DriveFrames drive = drive_frames(store, time_offset_s, margin_s + kJacobianLook_s);
  if (drive.size() == 0) return {};
  // Stage 2's frames at the exact centres of their slices, not the nearest already-decoded ones:
  // stage 1's clustered groups pulled them together and cost 0.0006 deg yaw MAE over 30 seeds
  // (paper_tables, bench/RESULTS.md); the checks after stage 1 sample these frames anyway.
  drive.decoded.clear();
  const double total = drive.motion_m.back();
  const std::size_t by_motion = static_cast<std::size_t>(total / std::max(config.min_motion_m, 1e-6)) + 1;
  const std::size_t by_spacing =
      config.max_spacing_m > 0.0 ? static_cast<std::size_t>(total / config.max_spacing_m) + 1 : 0;
  const std::size_t wanted = std::max(config.max_frames, by_spacing);
  std::vector<std::size_t> picked;
  for (std::size_t k : spread_over_motion(drive, std::max<std::size_t>(1, std::min(wanted, by_motion))))
    picked.push_back(drive.index[k]);
  return picked;
}

JointRefineResult refine_joint(const std::vector<RefineLidar>& lidars, const RefineConfig& config,
                               const std::function<void(double)>& progress) {
  const auto t0 = Clock::now();
  JointRefineResult result;
  result.lidars.resize(lidars.size());
  States start;
  for (std::size_t l = 0; l < lidars.size(); ++l) {
    result.lidars[l].T_ins_lidar = lidars[l].T_ins_lidar_start;
    result.lidars[l].time_offset_s = lidars[l].time_offset_start_s;
    start.push_back({lidars[l].T_ins_lidar_start, lidars[l].time_offset_start_s});
  }
  auto finish = [&] {
    result.outcome.wall_time_s = std::chrono::duration<double>(Clock::now() - t0).count();
    for (RefineResult& r : result.lidars) r.outcome.wall_time_s = result.outcome.wall_time_s;
    if (progress) progress(1.0);
    return result;
  };
  const std::vector<bool> offset_free = offsets_free(lidars, config);
  std::vector<std::size_t> frames_used, points_used;
  Problem p = joint_problem(lidars, config, offset_free, true, frames_used, points_used);
  for (std::size_t l = 0; l < lidars.size(); ++l) {
    if (frames_used[l] >= kMinFrames) continue;
    result.outcome.status = StageStatus::kUndetermined;
    result.outcome.message = lidar_prefix(lidars[l]) + "stage 2 (refinement): only " + std::to_string(frames_used[l]) +
                             " usable frames with motion between them (need " + std::to_string(kMinFrames) +
                             "); the vehicle barely moves, so no degree of freedom is determined";
    for (RefineResult& r : result.lidars) r.outcome = result.outcome;
    return finish();
  }
  if (progress) progress(0.1);
  for (std::size_t l = 0; l < lidars.size(); ++l) {
    result.lidars[l].frames_used = frames_used[l];
    result.lidars[l].points_used = points_used[l];
    result.lidars[l].time_offset_estimated = offset_free[l];
    result.lidars[l].outcome.status = StageStatus::kOk;
  }
  result.outcome.status = StageStatus::kOk;

  Search search;
  search.rounds.resize(lidars.size());
  const States final_states = config.method == RefineMethod::kOccupancyGrid
                                  ? grid_search(p, start, offset_free, config, search, progress)
                                  : gauss_newton(p, start, offset_free, config, search, progress);
  distribute(search, final_states, result);
  if (!search.undetermined) set_stddevs(search, offset_free, p.tz_free, config, result.lidars);
  if (config.extrinsic_only) return finish();
  const std::vector<std::size_t> before = occupied_per_lidar(p, start, config.occupancy_voxel_m);
  const std::vector<std::size_t> after = occupied_per_lidar(p, final_states, config.occupancy_voxel_m);
  for (std::size_t l = 0; l < lidars.size(); ++l) {
    result.lidars[l].occupied_voxels_before = before[l];
    result.lidars[l].occupied_voxels_after = after[l];
  }
  return finish();
}

Vec7 random_walk_stddev(const RefineResult& r, const Vec3& rms_about_mean_m, double span_s) {
  const std::size_t n = r.ins_shift.size();
  if (n < 2 || !(span_s > 0.0)) return Vec7::Zero();
  // sum_f S_f (e_f - mean e) = sum_f (S_f - mean S) e_f, and a walk is the integral of its steps:
  // each step between sorted frame times moves every later frame alike, so its variance
  // (q dt per axis) enters through the suffix sum of S - mean S.
  std::vector<std::size_t> order(n);
  for (std::size_t f = 0; f < n; ++f) order[f] = f;
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return r.ins_shift_t_s[a] < r.ins_shift_t_s[b]; });
  Eigen::Matrix<double, 7, 3> mean = Eigen::Matrix<double, 7, 3>::Zero();
  for (const auto& S : r.ins_shift) mean += S;
  mean /= static_cast<double>(n);
  const Vec3 q = 6.0 * rms_about_mean_m.cwiseAbs2() / span_s;
  Vec7 var = Vec7::Zero();
  Eigen::Matrix<double, 7, 3> suffix = Eigen::Matrix<double, 7, 3>::Zero();
  for (std::size_t k = n; k-- > 1;) {
    suffix += r.ins_shift[order[k]] - mean;
    const double dt = r.ins_shift_t_s[order[k]] - r.ins_shift_t_s[order[k - 1]];
    var += dt * (suffix.cwiseAbs2() * q);
  }
  return var.cwiseSqrt();
}

RefineResult refine_extrinsic(const FrameStore& store, const std::vector<std::size_t>& frames,
                              const Iso3& T_ins_lidar_start, double time_offset_start_s, const RefineConfig& config,
                              const std::function<void(double)>& progress) {
  const RefineLidar one{"", &store, frames, T_ins_lidar_start, time_offset_start_s, true};
  return std::move(refine_joint({one}, config, progress).lidars.front());
}

std::vector<JointRefineSystem> refine_joint_systems(const std::vector<RefineLidar>& lidars,
                                                    const std::vector<std::vector<std::pair<Iso3, double>>>& states,
                                                    const RefineConfig& config) {
  std::vector<std::size_t> frames_used, points_used;
  const Problem p = joint_problem(lidars, config, offsets_free(lidars, config), false, frames_used, points_used);
  std::vector<JointRefineSystem> out;
  std::vector<Vec3f> scratch;
  PlaneGrouping planes;
  for (const auto& state : states) {
    States s;
    for (const auto& [T_ins_lidar, time_offset_s] : state) s.push_back({T_ins_lidar, time_offset_s});
    const NormalEquations ne = build_normal_equations(p, s, config, scratch, planes);
    out.push_back({ne.cost, ne.gradient(), ne.hessian(), ne.n});
  }
  return out;
}

std::vector<RefineSystem> refine_systems(const FrameStore& store, const std::vector<std::size_t>& frames,
                                         const std::vector<std::pair<Iso3, double>>& states, const RefineConfig& config) {
  const RefineLidar one{"", &store, frames, Iso3::Identity(), 0.0, true};
  std::vector<std::vector<std::pair<Iso3, double>>> joint_states;
  for (const auto& state : states) joint_states.push_back({state});
  std::vector<RefineSystem> out;
  for (const JointRefineSystem& sys : refine_joint_systems({one}, joint_states, config))
    out.push_back({sys.cost, sys.gradient, sys.hessian, sys.points});
  return out;
}

JointRefineResult refine_joint_checked(const std::vector<RefineLidar>& lidars, double max_speed_mps,
                                       const RefineConfig& config, const std::function<void(double)>& progress,
                                       std::vector<std::string>& warnings) {
  JointRefineResult joint = refine_joint(lidars, config, progress);
  if (!joint.outcome.ok()) return joint;
  std::vector<RefineLidar> fixed = lidars;
  bool any = false;
  for (std::size_t l = 0; l < lidars.size(); ++l) {
    const RefineResult& refine = joint.lidars[l];
    const Iso3& T_start = lidars[l].T_ins_lidar_start;
    const double shift_m = (refine.T_ins_lidar.translation() - T_start.translation()).head<2>().norm();
    const double explained_m = max_speed_mps * std::abs(refine.time_offset_s - lidars[l].time_offset_start_s) +
                               config.max_unexplained_shift_m;
    if (!refine.time_offset_estimated || shift_m <= explained_m) continue;
    warnings.push_back(lidar_prefix(lidars[l]) + fmt::format(
        "stage 2 moved the lever arm by {:.1f} cm with a time offset of {:+.1f} ms, more than the offset explains "
        "({:.1f} cm): this drive cannot separate the time offset from the lever arm (too few vertical structures?); "
        "stage 2 repeated with the offset fixed at {:+.1f} ms",
        100.0 * shift_m, 1e3 * refine.time_offset_s, 100.0 * explained_m, 1e3 * lidars[l].time_offset_start_s));
    fixed[l].estimate_time_offset = false;
    any = true;
  }
  return any ? refine_joint(fixed, config, progress) : joint;
}

RefineResult refine_checked(const FrameStore& store, const std::vector<std::size_t>& frames,
                            const Iso3& T_ins_lidar_start, double time_offset_start_s, double max_speed_mps,
                            const RefineConfig& config, const std::function<void(double)>& progress,
                            std::string& warning) {
  const RefineLidar one{"", &store, frames, T_ins_lidar_start, time_offset_start_s, true};
  std::vector<std::string> warnings;
  JointRefineResult joint = refine_joint_checked({one}, max_speed_mps, config, progress, warnings);
  if (!warnings.empty()) warning = warnings.front();
  return std::move(joint.lidars.front());
}

}  // namespace insalign
