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

// The reduced frames and everything every evaluation needs about them.
struct Problem {
  const PoseStream* poses = nullptr;
  std::vector<Sweep> frames;
  std::vector<std::size_t> first;  // frames[f] occupies points [first[f], first[f+1]) of a map
  std::vector<std::uint16_t> frame_of;
  std::size_t points() const { return first.back(); }
};

Problem make_problem(const PoseStream& poses, std::vector<Sweep> frames) {
  Problem p;
  p.poses = &poses;
  p.frames = std::move(frames);
  p.first.assign(1, 0);
  for (const Sweep& s : p.frames) p.first.push_back(p.first.back() + s.size());
  p.frame_of.resize(p.points());
  for (std::size_t f = 0; f < p.frames.size(); ++f) {
    std::fill(p.frame_of.begin() + p.first[f], p.frame_of.begin() + p.first[f + 1], static_cast<std::uint16_t>(f));
  }
  return p;
}

// The stitched map: every point deskewed through the INS poses at its own time.
void place_all(const Problem& p, const State& s, std::vector<Vec3f>& p_world) {
  p_world.resize(p.points());
  PlaceOptions options;
  options.time_offset_s = s.time_offset_s;
  tbb::parallel_for(std::size_t{0}, p.frames.size(), [&](std::size_t f) {
    const std::vector<Vec3f> w = sweep_to_world(p.frames[f], *p.poses, s.T_ins_lidar, options);
    std::copy(w.begin(), w.end(), p_world.begin() + static_cast<std::ptrdiff_t>(p.first[f]));
  });
}

double occupancy(const Problem& p, const State& s, double voxel_m, std::vector<Vec3f>& scratch) {
  place_all(p, s, scratch);
  return staggered_occupancy(scratch, voxel_m);
}

// INS pose and its velocity at knots over a sweep, for the Jacobians (values come from
// sweep_to_world; these only need to be close).
struct Knots {
  double t0 = 0.0, step = 1.0;
  std::vector<Mat3> R_world_ins;
  std::vector<Vec3> t_world_ins, v_world, w_world;  // position, velocity, angular velocity (world)
  int nearest(double dt_from_t0) const {
    return std::clamp(static_cast<int>(std::lround(dt_from_t0 / step)), 0, static_cast<int>(R_world_ins.size()) - 1);
  }
};
Knots make_knots(const Sweep& sweep, const PoseStream& poses, double time_offset_s) {
  double lo = 0.0, hi = 0.0;
  if (sweep.has_time()) {
    lo = *std::min_element(sweep.dt_s.begin(), sweep.dt_s.end());
    hi = *std::max_element(sweep.dt_s.begin(), sweep.dt_s.end());
  }
  Knots k;
  const int n = std::max(2, static_cast<int>(std::ceil((hi - lo) / 0.01)) + 1);
  k.t0 = lo;
  k.step = std::max((hi - lo) / (n - 1), 1e-6);
  const double h = 0.005;
  for (int i = 0; i < n; ++i) {
    const double t = sweep.t_end_s + time_offset_s + lo + i * k.step;
    const Iso3 T = poses.T_world_ins(t);
    const double ta = std::max(t - h, poses.t_begin()), tb = std::min(t + h, poses.t_end());
    const Iso3 Ta = poses.T_world_ins(ta), Tb = poses.T_world_ins(tb);
    k.R_world_ins.push_back(T.linear());
    k.t_world_ins.push_back(T.translation());
    k.v_world.push_back((Tb.translation() - Ta.translation()) / (tb - ta));
    k.w_world.push_back(Ta.linear() * so3_log(Ta.linear().transpose() * Tb.linear()) / (tb - ta));
  }
  return k;
}

struct NormalEquations {
  Mat7 H = Mat7::Zero();
  Vec7 g = Vec7::Zero();
  double cost = 0.0;      // sum of robust-weighted squared distances
  double sq = 0.0;        // sum of squared distances (unweighted)
  std::size_t n = 0;
  NormalEquations& operator+=(const NormalEquations& o) {
    H += o.H;
    g += o.g;
    cost += o.cost;
    sq += o.sq;
    n += o.n;
    return *this;
  }
};


// Point-to-plane normal equations of the stitched map against its own local planes: at a fixed
// set of planes this is the gradient of the BALM smallest-eigenvalue cost.
// Re-fits the planes of a frozen point grouping to the current map (centroid and normal only).
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
    plane.lambda_min = std::max(0.0, es.eigenvalues()(0));
  });
}

// lp: the planes; empty = fit them from the current map, else keep its point grouping (a fixed
// grouping makes the cost smooth, so the last iterations converge instead of jittering as
// voxels flip in and out of the planar set).
NormalEquations build_normal_equations(const Problem& p, const State& s, const RefineConfig& config,
                                       std::vector<Vec3f>& p_world, LocalPlanes& lp) {
  place_all(p, s, p_world);
  if (lp.planes.empty()) {
    lp = fit_local_planes(p_world, plane_thickness_config(config));
  } else {
    refit_planes(p_world, lp);
  }
  std::vector<Knots> knots(p.frames.size());
  tbb::parallel_for(std::size_t{0}, p.frames.size(),
                    [&](std::size_t f) { knots[f] = make_knots(p.frames[f], *p.poses, s.time_offset_s); });
  const Mat3 R_ins_lidar = s.T_ins_lidar.linear();
  tbb::combinable<NormalEquations> acc;
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, lp.planes.size(), 256), [&](const auto& r) {
    NormalEquations& ne = acc.local();
    for (std::size_t k = r.begin(); k < r.end(); ++k) {
      const LocalPlane& plane = lp.planes[k];
      // The plane moves with its points: eliminating its offset (the centroid) subtracts the
      // plane's mean Jacobian; without it every step is mostly absorbed by the re-fitted plane.
      Mat7 sum_JJ = Mat7::Zero();
      Vec7 sum_J = Vec7::Zero();
      double sum_w = 0.0;
      for (std::uint32_t m = plane.first; m < plane.first + plane.count; ++m) {
        const std::uint32_t idx = lp.point_index[m];
        const std::size_t f = p.frame_of[idx];
        const Sweep& sweep = p.frames[f];
        const std::size_t j = idx - p.first[f];
        const Knots& kn = knots[f];
        const int kk = kn.nearest(sweep.has_time() ? sweep.dt_s[j] - kn.t0 : -kn.t0);
        const Vec3 q = p_world[idx].cast<double>();
        const double res = plane.normal.dot(q - plane.centroid);
        const Vec3 a = R_ins_lidar * sweep.p_lidar[j].cast<double>();  // rotated point, INS axes
        const Vec3 m_ins = kn.R_world_ins[kk].transpose() * plane.normal;
        Vec7 J;
        J.head<3>() = m_ins;
        J.segment<3>(3) = a.cross(m_ins);
        J(kTimeIndex) = plane.normal.dot(kn.v_world[kk] + kn.w_world[kk].cross(q - kn.t_world_ins[kk]));
        const double ar = std::abs(res);
        const double w = ar <= config.huber_m ? 1.0 : config.huber_m / ar;
        sum_JJ.selfadjointView<Eigen::Upper>().rankUpdate(J, w);
        sum_J += w * J;
        sum_w += w;
        ne.g += w * res * J;
        ne.cost += w * res * res;
        ne.sq += res * res;
        ++ne.n;
      }
      ne.H += sum_JJ;
      ne.H.selfadjointView<Eigen::Upper>().rankUpdate(sum_J, -1.0 / sum_w);
    }
  });
  NormalEquations total;
  acc.combine_each([&](const NormalEquations& ne) { total += ne; });
  total.H = total.H.selfadjointView<Eigen::Upper>();
  return total;
}

std::vector<int> active_dofs(const RefineConfig& c) {
  std::vector<int> dofs = {0, 1};
  if (c.estimate_tz) dofs.push_back(2);
  dofs.insert(dofs.end(), {3, 4, 5});
  if (c.estimate_time_offset) dofs.push_back(kTimeIndex);
  return dofs;
}

std::string fmt_m(double v) { return fmt::format("{}", v); }

// ---- The paper's search: coordinate-wise grid search with shrinking steps on occupancy. ----
State grid_search(const Problem& p, const State& start, const RefineConfig& config, RefineResult& result,
                  const std::function<void(double)>& progress) {
  std::vector<Vec3f> scratch;
  State best = start;
  double best_cost = occupancy(p, best, config.occupancy_voxel_m, scratch);
  ++result.evaluations;
  result.crispness_before = best_cost;
  const std::vector<int> dofs = active_dofs(config);
  // Time offset first: it moves points the most; then rotations, then translations.
  std::vector<int> order;
  if (config.estimate_time_offset) order.push_back(kTimeIndex);
  for (int d : {5, 3, 4, 0, 1, 2}) {
    if (std::find(dofs.begin(), dofs.end(), d) != dofs.end()) order.push_back(d);
  }
  double scale = 1.0;
  for (int round = 0; round < config.grid_rounds; ++round) {
    for (int pass = 0; pass < config.grid_sweeps_per_round; ++pass) {
      for (int d : order) {
        const double range = scale * (d < 3 ? config.grid_trans_range_m
                                            : d < 6 ? config.grid_rot_range_deg * kRadPerDeg
                                                    : config.time_offset_range_s);
        const double step = range / std::max(1, config.grid_steps);
        State centre = best;
        for (int i = -config.grid_steps; i <= config.grid_steps; ++i) {
          if (i == 0) continue;
          Vec7 delta = Vec7::Zero();
          delta(d) = i * step;
          const State cand = apply(centre, delta);
          if (d == kTimeIndex && std::abs(cand.time_offset_s - start.time_offset_s) > config.time_offset_range_s + 1e-12) {
            continue;
          }
          const double cost = occupancy(p, cand, config.occupancy_voxel_m, scratch);
          ++result.evaluations;
          if (cost < best_cost) {
            best_cost = cost;
            best = cand;
          }
        }
      }
    }
    result.rounds.push_back({round, best.T_ins_lidar, best.time_offset_s, best_cost});
    if (progress) progress(0.1 + 0.9 * (round + 1) / config.grid_rounds);
    scale *= config.grid_shrink;
  }
  result.crispness_after = best_cost;
  result.measure = "occupied voxels (" + fmt_m(config.occupancy_voxel_m) + " m, mean of 2 staggered grids)";
  result.converged = true;
  return best;
}

// ---- Smooth variant: plane thickness by Gauss-Newton, with a coarse offset scan first. ----
State gauss_newton(const Problem& p, const State& start, const RefineConfig& config, RefineResult& result,
                   const std::function<void(double)>& progress) {
  std::vector<Vec3f> scratch;
  State s = start;
  // A wrong offset of tens of milliseconds smears the map by decimetres, beyond the reach of the
  // local planes; a coarse occupancy scan puts Gauss-Newton within a step of the optimum.
  if (config.estimate_time_offset && config.time_offset_scan_step_s > 0.0) {
    const int n = static_cast<int>(std::floor(config.time_offset_range_s / config.time_offset_scan_step_s + 1e-9));
    // Every few frames suffice for a decimetre-scale smear; the scan is then a small part of the stage.
    const std::size_t stride = (p.frames.size() + 39) / 40;
    std::vector<Sweep> subset;
    for (std::size_t f = 0; f < p.frames.size(); f += stride) subset.push_back(p.frames[f]);
    const Problem coarse = make_problem(*p.poses, std::move(subset));
    double best_cost = 0.0;
    double best_offset = start.time_offset_s;
    for (int i = -n; i <= n; ++i) {
      State cand = start;
      cand.time_offset_s = start.time_offset_s + i * config.time_offset_scan_step_s;
      place_all(coarse, cand, scratch);
      const double cost = static_cast<double>(count_occupied_voxels(scratch, config.time_offset_scan_voxel_m));
      ++result.evaluations;
      if (i == -n || cost < best_cost) {
        best_cost = cost;
        best_offset = cand.time_offset_s;
      }
    }
    s.time_offset_s = best_offset;
  }
  const std::vector<int> dofs = active_dofs(config);
  const int n_dof = static_cast<int>(dofs.size());
  Eigen::MatrixXd H_active;
  double sigma2 = 0.0;
  LocalPlanes planes;
  for (int it = 0; it < config.max_iterations; ++it) {
    if (it < config.refit_iterations) planes = LocalPlanes{};
    const NormalEquations ne = build_normal_equations(p, s, config, scratch, planes);
    ++result.evaluations;
    result.planes_used = planes.planes.size();
    const double rms = ne.n > 0 ? std::sqrt(ne.sq / static_cast<double>(ne.n)) : 0.0;
    if (it == 0) result.crispness_before = rms;
    result.crispness_after = rms;
    if (ne.n < 100) {
      result.outcome.status = StageStatus::kUndetermined;
      result.outcome.message = "stage 2: fewer than 100 points on local planes in the stitched map";
      return start;
    }
    H_active.resize(n_dof, n_dof);
    Eigen::VectorXd g_active(n_dof);
    for (int a = 0; a < n_dof; ++a) {
      g_active(a) = ne.g(dofs[a]);
      for (int b = 0; b < n_dof; ++b) H_active(a, b) = ne.H(dofs[a], dofs[b]);
    }
    sigma2 = ne.cost / std::max<double>(1.0, static_cast<double>(ne.n) - n_dof);
    Eigen::MatrixXd A = H_active;
    for (int a = 0; a < n_dof; ++a) A(a, a) += 1e-9 * H_active(a, a) + 1e-12;
    const Eigen::VectorXd dx = A.ldlt().solve(-g_active);
    Vec7 delta = Vec7::Zero();
    for (int a = 0; a < n_dof; ++a) delta(dofs[a]) = dx(a);
    // Trust region: planes re-fitted from a smeared map only point the way for small steps.
    const double rot = delta.segment<3>(3).norm(), trans = delta.head<3>().norm();
    const double shrink = std::min({1.0, (0.5 * kRadPerDeg) / std::max(rot, 1e-15), 0.05 / std::max(trans, 1e-15),
                                    0.01 / std::max(std::abs(delta(kTimeIndex)), 1e-15)});
    delta *= shrink;
    s = apply(s, delta);
    result.rounds.push_back({it, s.T_ins_lidar, s.time_offset_s, rms});
    if (progress) progress(0.1 + 0.9 * (it + 1) / config.max_iterations);
    if (delta.segment<3>(3).norm() < config.converged_rot_deg * kRadPerDeg &&
        delta.head<3>().norm() < config.converged_trans_m && std::abs(delta(kTimeIndex)) < 1e-5) {
      result.converged = true;
      break;
    }
  }
  // 1-sigma from the information of the last iteration (points treated as independent, which
  // makes this optimistic; a guide to which DOF the drive pins down, not a guarantee).
  const Eigen::MatrixXd cov = sigma2 * H_active.ldlt().solve(Eigen::MatrixXd::Identity(n_dof, n_dof));
  for (int a = 0; a < n_dof; ++a) {
    const double sd = std::sqrt(std::max(0.0, cov(a, a)));
    if (dofs[a] == kTimeIndex) {
      result.time_offset_stddev_s = sd;
    } else {
      result.outcome.stddev(dofs[a]) = sd;
      result.outcome.determined[static_cast<std::size_t>(dofs[a])] = true;
    }
  }
  result.measure = "plane thickness RMS (m, " + fmt_m(config.plane_voxel_m) + " m planes)";
  return s;
}

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
  const DriveFrames drive =
      drive_frames(store, time_offset_s, margin_s + kJacobianLook_s);
  if (drive.size() == 0) return {};
  const double total = drive.motion_m.back();
  const std::size_t by_motion = static_cast<std::size_t>(total / std::max(config.min_motion_m, 1e-6)) + 1;
  std::vector<std::size_t> picked;
  for (std::size_t k : spread_over_motion(drive, std::max<std::size_t>(1, std::min(config.max_frames, by_motion))))
    picked.push_back(drive.index[k]);
  return picked;
}

RefineResult refine_extrinsic(const FrameStore& store, const std::vector<std::size_t>& frames,
                              const Iso3& T_ins_lidar_start, double time_offset_start_s, const RefineConfig& config,
                              const std::function<void(double)>& progress) {
  const auto t0 = Clock::now();
  RefineResult result;
  result.T_ins_lidar = T_ins_lidar_start;
  result.time_offset_s = time_offset_start_s;
  auto finish = [&] {
    result.outcome.wall_time_s = std::chrono::duration<double>(Clock::now() - t0).count();
    if (progress) progress(1.0);
    return result;
  };
  const double margin = config.estimate_time_offset ? config.time_offset_range_s : 0.0;
  std::vector<Sweep> sweeps = store.thinned(frames, config.filter);
  std::erase_if(sweeps, [&](const Sweep& s) {
    return !sweep_covered(store.poses(), s, time_offset_start_s, margin + kJacobianLook_s);
  });
  if (sweeps.size() < kMinFrames) {
    result.outcome.status = StageStatus::kUndetermined;
    result.outcome.message = "stage 2 (refinement): only " + std::to_string(sweeps.size()) +
                             " usable frames with motion between them (need " + std::to_string(kMinFrames) +
                             "); the vehicle barely moves, so no degree of freedom is determined";
    return finish();
  }
  Problem p = make_problem(store.poses(), std::move(sweeps));
  if (progress) progress(0.1);
  result.frames_used = p.frames.size();
  result.points_used = p.points();
  result.time_offset_estimated = config.estimate_time_offset;
  result.outcome.status = StageStatus::kOk;

  const State start{T_ins_lidar_start, time_offset_start_s};
  const State final_state = config.method == RefineMethod::kOccupancyGrid
                                ? grid_search(p, start, config, result, progress)
                                : gauss_newton(p, start, config, result, progress);
  std::vector<Vec3f> scratch;
  place_all(p, start, scratch);
  result.occupied_voxels_before = count_occupied_voxels(scratch, config.occupancy_voxel_m);
  place_all(p, final_state, scratch);
  result.occupied_voxels_after = count_occupied_voxels(scratch, config.occupancy_voxel_m);
  result.T_ins_lidar = final_state.T_ins_lidar;
  result.time_offset_s = final_state.time_offset_s;
  return finish();
}

std::vector<RefineSystem> refine_systems(const FrameStore& store, const std::vector<std::size_t>& frames,
                                         const std::vector<std::pair<Iso3, double>>& states, const RefineConfig& config) {
  const Problem p = make_problem(store.poses(), store.thinned(frames, config.filter));
  std::vector<RefineSystem> out;
  std::vector<Vec3f> scratch;
  LocalPlanes planes;
  for (const auto& [T_ins_lidar, time_offset_s] : states) {
    const NormalEquations ne = build_normal_equations(p, State{T_ins_lidar, time_offset_s}, config, scratch, planes);
    out.push_back({ne.cost, ne.g, ne.H, ne.n});
  }
  return out;
}

RefineResult refine_checked(const FrameStore& store, const std::vector<std::size_t>& frames,
                            const Iso3& T_ins_lidar_start, double time_offset_start_s, double max_speed_mps,
                            const RefineConfig& config, const std::function<void(double)>& progress,
                            std::string& warning) {
  RefineResult refine = refine_extrinsic(store, frames, T_ins_lidar_start, time_offset_start_s, config, progress);
  const double shift_m = (refine.T_ins_lidar.translation() - T_ins_lidar_start.translation()).head<2>().norm();
  const double explained_m =
      max_speed_mps * std::abs(refine.time_offset_s - time_offset_start_s) + config.max_unexplained_shift_m;
  if (!refine.outcome.ok() || !refine.time_offset_estimated || shift_m <= explained_m) return refine;
  warning = fmt::format(
      "stage 2 moved the lever arm by {:.1f} cm with a time offset of {:+.1f} ms, more than the offset explains "
      "({:.1f} cm): this drive cannot separate the time offset from the lever arm (too few vertical structures?); "
      "stage 2 repeated with the offset fixed at {:+.1f} ms",
      100.0 * shift_m, 1e3 * refine.time_offset_s, 100.0 * explained_m, 1e3 * time_offset_start_s);
  RefineConfig fixed_offset = config;
  fixed_offset.estimate_time_offset = false;
  return refine_extrinsic(store, frames, T_ins_lidar_start, time_offset_start_s, fixed_offset, progress);
}

}  // namespace insalign
