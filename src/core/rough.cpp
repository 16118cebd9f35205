#include "core/rough.hpp"

#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>
#include <tbb/blocked_range.h>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <chrono>
#include <cmath>

#include "core/deskew.hpp"
#include "core/plane_features.hpp"
#include "core/voxel_grid.hpp"

namespace insalign {

std::vector<RoughRound> default_rough_schedule() {
  //        window  stride  root   planar  robust  iterations
  return {
      {1, 1, 2.0, 0.15, 0.30, 6},   // a few consecutive frames: rotation from the travel direction
      {1, 1, 2.0, 0.08, 0.15, 5},
      {3, 2, 2.0, 0.08, 0.15, 5},   // about ten seconds: turns bring in x, y
      {0, 2, 1.5, 0.05, 0.08, 4},   // whole drive: every heading
      {0, 2, 1.0, 0.04, 0.05, 4},
  };
}

std::vector<RoughRound> multi_group_rounds(const std::vector<RoughRound>& rounds) {
  const auto first = std::find_if(rounds.begin(), rounds.end(), [](const RoughRound& r) { return r.window_groups != 1; });
  return first == rounds.end() ? rounds : std::vector<RoughRound>(first, rounds.end());
}

std::vector<RoughRound> pipeline_rounds(const RoughConfig& config, bool near_start, bool stage2_follows) {
  std::vector<RoughRound> rounds = config.rounds;
  if (config.near_start_skips_single_group_rounds && near_start) rounds = multi_group_rounds(rounds);
  if (config.stage2_skips_last_round && stage2_follows && rounds.size() > 1) rounds.pop_back();
  return rounds;
}

namespace {

using Mat4 = Eigen::Matrix4d;
using Mat34 = Eigen::Matrix<double, 3, 4>;
using Mat64 = Eigen::Matrix<double, 6, 4>;
using Mat63 = Eigen::Matrix<double, 6, 3>;

Mat3 skew(const Vec3& v) {
  Mat3 S;
  S << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return S;
}

Iso3 apply_update(const Iso3& T_ins_lidar, const Vec6& delta) { return perturb_in_ins_frame(T_ins_lidar, delta); }

/// The points of one frame inside one plane voxel, summarised by their moments in the frame's
/// (deskewed) LiDAR coordinates: M = sum [1; p] [1; p]^T. Point-to-plane costs and their
/// derivatives are quadratic forms in M, so each cluster costs the same however many points it has.
struct Cluster {
  std::uint32_t frame = 0;
  Mat4 M = Mat4::Zero();
};

struct Problem {
  std::vector<Iso3> T_world_ins;                 ///< per local frame, at the frame time
  /// Per plane, its clusters: each plane's own vector, as built, moved and never copied (a
  /// round holds a few hundred thousand; copying them into one array kept a core idle).
  std::vector<std::vector<Cluster>> planes_clusters;
  std::size_t residuals = 0;
  std::size_t planes() const { return planes_clusters.size(); }
};

struct Accum {
  Mat6 H = Mat6::Zero();
  Vec6 g = Vec6::Zero();
  double cost = 0.0;        ///< robust (Cauchy) cost, m^2
  double weighted_sq = 0.0; ///< sum of weight * squared distances
  double weighted_n = 0.0;  ///< sum of weight * points
  Accum& operator+=(const Accum& o) {
    H += o.H;
    g += o.g;
    cost += o.cost;
    weighted_sq += o.weighted_sq;
    weighted_n += o.weighted_n;
    return *this;
  }
};

/// Cost (and, if wanted, the Gauss-Newton system with the plane parameters eliminated) of the
/// extrinsic. Each plane is refitted to its points at this extrinsic with Cauchy weights per
/// cluster, so the cost is the point-to-plane cost minimised over the planes (BALM's eigenvalue
/// cost), and the Schur complement gives the joint Gauss-Newton step.
// One plane's clusters placed at the current extrinsic: cluster c's points map to the world as
// A[c] p + b[c]. Reused per thread.
struct PlaneScratch {
  std::vector<Mat3> A;
  std::vector<Vec3> b;
  std::vector<double> w, e;  // Cauchy weights, squared distances per cluster
  std::vector<Vec3> s1;      // per cluster: its points' world sum and second moment (the same in
  std::vector<Mat3> s2;      // both fits, so computed once)
  std::vector<Eigen::Vector4d> h;  // per cluster: r = h^T [1; p] at the final plane
};

struct PlaneFit {
  Vec3 centre, normal, u, v;  // normal: the smallest eigenvector; u, v span the plane
};

// The plane through the clusters, fitted twice: the second time with the Cauchy IRLS weights of
// each cluster's RMS distance from the first; leaves the final weights and distances in `s`.
PlaneFit fit_weighted_plane(const std::vector<Cluster>& clusters, double s2, PlaneScratch& s) {
  PlaneFit f;
  const std::size_t nc = s.A.size();
  s.s1.resize(nc), s.s2.resize(nc), s.h.resize(nc);
  for (std::size_t c = 0; c < nc; ++c) {
    const Mat4& M = clusters[c].M;
    const double n = M(0, 0);
    const Vec3 As1 = s.A[c] * M.block<3, 1>(1, 0);
    s.s1[c] = n * s.b[c] + As1;
    s.s2[c] = s.A[c] * M.block<3, 3>(1, 1) * s.A[c].transpose() + As1 * s.b[c].transpose() + s.b[c] * As1.transpose() +
              n * s.b[c] * s.b[c].transpose();
  }
  for (int pass = 0; pass < 2; ++pass) {
    double N = 0.0;
    Vec3 S1 = Vec3::Zero();
    Mat3 S2 = Mat3::Zero();
    for (std::size_t c = 0; c < nc; ++c) {
      N += s.w[c] * clusters[c].M(0, 0);
      S1 += s.w[c] * s.s1[c];
      S2 += s.w[c] * s.s2[c];
    }
    f.centre = S1 / N;
    const Eigen::SelfAdjointEigenSolver<Mat3> eig(S2 / N - f.centre * f.centre.transpose());
    f.normal = eig.eigenvectors().col(0);
    f.u = eig.eigenvectors().col(1);
    f.v = eig.eigenvectors().col(2);
    for (std::size_t c = 0; c < nc; ++c) {
      Eigen::Vector4d& h = s.h[c];
      h << f.normal.dot(s.b[c] - f.centre), s.A[c].transpose() * f.normal;
      const Mat4& M = clusters[c].M;
      s.e[c] = h.dot(M * h);
      s.w[c] = 1.0 / (1.0 + s.e[c] / M(0, 0) / s2);
    }
  }
  return f;
}

// The plane's cost and, with derivatives, its Gauss-Newton terms with the plane's own three
// parameters eliminated (Schur complement), into acc.
void accumulate_plane(const Problem& problem, const std::vector<Cluster>& clusters, const Mat3& R, double s2,
                      bool derivatives, const PlaneFit& f, const PlaneScratch& s, Accum& acc) {
  Mat6 Hpp = Mat6::Zero();
  Mat63 Hpl = Mat63::Zero();
  Mat3 Hll = Mat3::Zero();
  Vec6 gp = Vec6::Zero();
  Vec3 gl = Vec3::Zero();
  for (std::size_t c = 0; c < s.A.size(); ++c) {
    const Mat4& M = clusters[c].M;
    const double n = M(0, 0);
    acc.cost += n * s2 * std::log1p(s.e[c] / (n * s2));
    acc.weighted_sq += s.w[c] * s.e[c];
    acc.weighted_n += s.w[c] * n;
    if (!derivatives) continue;
    const Mat3& R_wi = problem.T_world_ins[clusters[c].frame].linear();
    const Eigen::Vector4d& h = s.h[c];
    // Per point r = h^T [1; p]. Pose Jacobian (rho, w) = P [1; p], plane Jacobian = L [1; p].
    const Vec3 m = R_wi.transpose() * f.normal;
    Mat64 P = Mat64::Zero();
    P.block<3, 1>(0, 0) = m;
    P.block<3, 3>(3, 1) = -skew(m) * R;
    Mat34 L = Mat34::Zero();
    L(0, 0) = f.u.dot(s.b[c] - f.centre);
    L.block<1, 3>(0, 1) = (s.A[c].transpose() * f.u).transpose();
    L(1, 0) = f.v.dot(s.b[c] - f.centre);
    L.block<1, 3>(1, 1) = (s.A[c].transpose() * f.v).transpose();
    L(2, 0) = -1.0;
    const Mat64 PM = s.w[c] * P * M;
    const Mat34 LM = s.w[c] * L * M;
    Hpp += PM * P.transpose();
    Hpl += PM * L.transpose();
    Hll += LM * L.transpose();
    gp += PM * h;
    gl += LM * h;
  }
  if (!derivatives) return;
  Hll += 1e-9 * Mat3::Identity();
  const Eigen::LDLT<Mat3> ldlt(Hll);
  acc.H += Hpp - Hpl * ldlt.solve(Hpl.transpose());
  acc.g += gp - Hpl * ldlt.solve(gl);
}

Accum evaluate(const Problem& problem, const Iso3& T_ins_lidar, double robust_scale_m, bool derivatives) {
  const Mat3 R = T_ins_lidar.linear();
  const Vec3 t = T_ins_lidar.translation();
  const double s2 = robust_scale_m * robust_scale_m;
  auto body = [&](const tbb::blocked_range<std::size_t>& range, Accum acc) {
    PlaneScratch s;
    for (std::size_t j = range.begin(); j != range.end(); ++j) {
      const std::vector<Cluster>& clusters = problem.planes_clusters[j];
      const std::size_t nc = clusters.size();
      s.A.resize(nc);
      s.b.resize(nc);
      s.e.resize(nc);
      s.w.assign(nc, 1.0);
      for (std::size_t c = 0; c < nc; ++c) {
        const Iso3& T_wi = problem.T_world_ins[clusters[c].frame];
        s.A[c] = T_wi.linear() * R;
        s.b[c] = T_wi.linear() * t + T_wi.translation();
      }
      accumulate_plane(problem, clusters, R, s2, derivatives, fit_weighted_plane(clusters, s2, s), s, acc);
    }
    return acc;
  };
  return tbb::parallel_deterministic_reduce(
      tbb::blocked_range<std::size_t>(0, problem.planes(), 64), Accum{}, body,
      [](Accum a, const Accum& b) { return a += b; });
}


/// Builds the plane clusters of one window of frames at the current extrinsic.
void add_window(const std::vector<std::uint32_t>& frames, const std::vector<std::vector<Vec3f>>& p_lidar,
                const Problem& placed, const Iso3& T_ins_lidar, const PlaneFeatureConfig& plane_config,
                std::size_t min_frames, Problem& problem) {
  // The window's points frame after frame; begin[n]: the first point of frames[n] (no per-point
  // frame and index arrays: a whole-drive window has millions of points).
  std::vector<std::size_t> begin;
  std::size_t total = 0;
  for (std::uint32_t f : frames) begin.push_back(total), total += p_lidar[f].size();
  // Frames and planes in parallel (a whole-drive window is one window: its round had a core idle).
  std::vector<Vec3f> p_world(total);
  tbb::parallel_for(std::size_t{0}, frames.size(), [&](std::size_t n) {
    const std::uint32_t f = frames[n];
    const Eigen::Isometry3f T_world_lidar = (placed.T_world_ins[f] * T_ins_lidar).cast<float>();
    for (std::size_t i = 0; i < p_lidar[f].size(); ++i) p_world[begin[n] + i] = T_world_lidar * p_lidar[f][i];
  });
  std::vector<Plane> planes = extract_planes(p_world, plane_config);
  p_world = {};
  std::vector<std::vector<Cluster>> per_plane(planes.size());
  tbb::parallel_for(std::size_t{0}, planes.size(), [&](std::size_t j) {
    std::vector<std::uint32_t>& members = planes[j].point_indices;  // ascending: frame by frame
    if (members.empty()) return;
    if (!std::is_sorted(members.begin(), members.end())) std::sort(members.begin(), members.end());
    std::vector<Cluster>& clusters = per_plane[j];
    const std::size_t n0 = std::upper_bound(begin.begin(), begin.end(), members.front()) - begin.begin() - 1;
    // One cluster per frame the plane spans: counted first, so the vector is allocated once at
    // its size (grown by push_back, a whole-drive window's clusters were 140 MB of a check's peak).
    std::size_t n = n0, frames_spanned = 1;
    for (std::uint32_t k : members) {
      const std::size_t before = n;
      while (n + 1 < begin.size() && begin[n + 1] <= k) ++n;
      if (n != before && frames[n] != frames[before]) ++frames_spanned;
    }
    clusters.reserve(frames_spanned);
    n = n0;
    for (std::uint32_t k : members) {
      while (n + 1 < begin.size() && begin[n + 1] <= k) ++n;
      const std::uint32_t f = frames[n];
      if (clusters.empty() || clusters.back().frame != f) clusters.push_back({f, Mat4::Zero()});
      Eigen::Vector4d q;
      q << 1.0, p_lidar[f][k - begin[n]].cast<double>();
      add_outer_upper(clusters.back().M, q);
    }
    for (Cluster& c : clusters) mirror_upper(c.M);
  });
  for (std::size_t j = 0; j < planes.size(); ++j) {
    if (per_plane[j].size() < min_frames) continue;
    problem.planes_clusters.push_back(std::move(per_plane[j]));
    problem.residuals += planes[j].point_indices.size();
  }
}

// Appends the planes (clusters) of `part`, built over the same local frames, to `problem`.
void append_planes(Problem&& part, Problem& problem) {
  for (std::vector<Cluster>& clusters : part.planes_clusters) problem.planes_clusters.push_back(std::move(clusters));
  problem.residuals += part.residuals;
}

}  // namespace


PointPlaneSystem point_plane_system(const std::vector<PlaneObservation>& observations, const Iso3& T_ins_lidar,
                                    double robust_scale_m) {
  Problem problem;
  for (std::size_t k = 0; k < observations.size(); ++k) {
    const PlaneObservation& o = observations[k];
    if (k == 0 || o.plane != observations[k - 1].plane) problem.planes_clusters.emplace_back();
    problem.T_world_ins.push_back(o.T_world_ins);
    Cluster c;
    c.frame = static_cast<std::uint32_t>(k);
    for (const Vec3f& p : o.p_lidar) {
      Eigen::Vector4d q;
      q << 1.0, p.cast<double>();
      c.M += q * q.transpose();
    }
    problem.planes_clusters.back().push_back(c);
  }
  const Accum acc = evaluate(problem, T_ins_lidar, robust_scale_m, true);
  PointPlaneSystem system;
  system.cost = acc.cost;
  system.gradient = acc.g;
  system.hessian = acc.H;
  system.sigma_m = std::sqrt(acc.weighted_sq / std::max(acc.weighted_n, 1.0));
  return system;
}

FrameGroups rough_frame_groups(const FrameStore& store, const RoughConfig& config, double time_offset_s) {
  const DriveFrames drive = drive_frames(store, time_offset_s);
  return spread_groups(drive, store.frames_config(), config.groups, config.frames_per_group);
}

namespace {

// The stage's frames, and its groups as local indices into them.
struct RoughFrames {
  std::vector<Sweep> sweeps;  ///< thinned; left empty where no round of the schedule reads the frame
  std::vector<std::vector<std::uint32_t>> groups;
  std::size_t loaded = 0;
};

// The windows of one round, as local frame indices: window_groups groups each (0: all), every
// frame_stride-th frame of a group (all of it when a window is one group).
std::vector<std::vector<std::uint32_t>> round_windows(const std::vector<std::vector<std::uint32_t>>& groups,
                                                      const RoughRound& round) {
  const std::size_t per_window = round.window_groups <= 0 ? groups.size() : static_cast<std::size_t>(round.window_groups);
  const std::size_t stride = per_window == 1 ? 1 : static_cast<std::size_t>(std::max(1, round.frame_stride));
  std::vector<std::vector<std::uint32_t>> windows;
  for (std::size_t g0 = 0; g0 < groups.size(); g0 += per_window) {
    std::vector<std::uint32_t>& window = windows.emplace_back();
    for (std::size_t g = g0; g < std::min(groups.size(), g0 + per_window); ++g)
      for (std::size_t n = 0; n < groups[g].size(); n += stride) window.push_back(groups[g][n]);
  }
  return windows;
}

// Only the frames some round reads are loaded (rounds of several groups take every other frame).
RoughFrames load_rough_frames(const FrameStore& store, const FrameGroups& groups, const RoughConfig& config) {
  RoughFrames out;
  std::vector<std::size_t> indices;
  for (const auto& g : groups) {
    out.groups.emplace_back();
    for (std::size_t i : g) {
      out.groups.back().push_back(static_cast<std::uint32_t>(indices.size()));
      indices.push_back(i);
    }
  }
  std::vector<char> read(indices.size(), 0);
  for (const RoughRound& round : config.rounds)
    for (const auto& window : round_windows(out.groups, round))
      for (std::uint32_t k : window) read[k] = 1;
  std::vector<std::size_t> wanted, local;
  for (std::size_t k = 0; k < indices.size(); ++k)
    if (read[k]) wanted.push_back(indices[k]), local.push_back(k);
  std::vector<Sweep> thinned = store.thinned(wanted, config.filter);
  out.sweeps.resize(indices.size());
  for (std::size_t j = 0; j < local.size(); ++j) out.sweeps[local[j]] = std::move(thinned[j]);
  out.loaded = wanted.size();
  return out;
}

// The plane clusters of every window of one round, at the current extrinsic.
Problem build_round_problem(const RoughFrames& frames, const PoseStream& poses, const Iso3& T_ins_lidar,
                            double time_offset_s, const RoughRound& round, const RoughConfig& config, int* windows) {
  PlaceOptions place;
  place.per_point_time = config.deskew;
  place.time_offset_s = time_offset_s;
  const std::vector<std::vector<std::uint32_t>> windows_frames = round_windows(frames.groups, round);
  std::vector<std::uint32_t> in_round;
  for (const auto& window : windows_frames) in_round.insert(in_round.end(), window.begin(), window.end());
  std::vector<std::vector<Vec3f>> p_lidar(frames.sweeps.size());
  Problem placed;
  placed.T_world_ins.resize(frames.sweeps.size());
  tbb::parallel_for(std::size_t{0}, in_round.size(), [&](std::size_t j) {
    const std::uint32_t k = in_round[j];
    p_lidar[k] = deskew_sweep(frames.sweeps[k], poses, T_ins_lidar, place);
    placed.T_world_ins[k] = frame_pose(frames.sweeps[k], poses, time_offset_s);
  });
  PlaneFeatureConfig plane_config;
  plane_config.root_voxel_m = round.root_voxel_m;
  plane_config.max_depth = config.max_depth;
  plane_config.planarity_sigma_m = round.planarity_sigma_m;
  plane_config.max_eigen_ratio = config.max_eigen_ratio;
  plane_config.min_points = config.min_points_per_plane;

  Problem problem;
  problem.T_world_ins = placed.T_world_ins;
  // Windows are independent: built in parallel, appended in window order (the same problem as
  // building them one after the other).
  std::vector<Problem> parts(windows_frames.size());
  tbb::parallel_for(std::size_t{0}, windows_frames.size(), [&](std::size_t w) {
    add_window(windows_frames[w], p_lidar, placed, T_ins_lidar, plane_config, config.min_frames_per_plane, parts[w]);
  });
  for (Problem& part : parts) append_planes(std::move(part), problem);
  *windows = static_cast<int>(windows_frames.size());
  return problem;
}

// Levenberg-Marquardt on the fixed association, moving only the DOFs in `free`.
// A step gaining less than this fraction of the cost is not taken.
constexpr double kNegligibleGain = 1e-5;

Accum solve_round(const Problem& problem, const RoughRound& round, const std::vector<int>& free, Accum acc,
                  Iso3& T_ins_lidar) {
  double lambda = 1e-3;
  for (int it = 0; it < round.iterations && !free.empty(); ++it) {
    const int n = static_cast<int>(free.size());
    Eigen::MatrixXd H(n, n);
    Eigen::VectorXd g(n);
    for (int a = 0; a < n; ++a) {
      g(a) = acc.g(free[a]);
      for (int b = 0; b < n; ++b) H(a, b) = acc.H(free[a], free[b]);
    }
    bool accepted = false;
    for (int attempt = 0; attempt < 6 && !accepted; ++attempt) {
      Eigen::MatrixXd Hd = H;
      for (int a = 0; a < n; ++a) Hd(a, a) += lambda * H(a, a) + 1e-12;
      const Eigen::VectorXd step = Hd.ldlt().solve(-g);
      Vec6 delta = Vec6::Zero();
      for (int a = 0; a < n; ++a) delta(free[a]) = step(a);
      const Iso3 candidate = apply_update(T_ins_lidar, delta);
      // A step the model says gains almost nothing (the association, not the solver, limits
      // now) is the last: taken without the evaluation that would only confirm it. g and H are
      // half the derivatives of the cost (a sum of squared distances). acc stays the last
      // evaluated point's, a step away.
      const double predicted = -2.0 * g.dot(step) - step.dot(H * step);
      if (predicted < kNegligibleGain * acc.cost || (delta.head<3>().norm() < 1e-5 && delta.tail<3>().norm() < 1e-6)) {
        T_ins_lidar = candidate;
        return acc;
      }
      const Accum trial = evaluate(problem, candidate, round.robust_scale_m, true);
      if (trial.cost > acc.cost) {
        lambda *= 5.0;
        continue;
      }
      const bool negligible = acc.cost - trial.cost < kNegligibleGain * acc.cost;
      T_ins_lidar = candidate;
      acc = trial;
      lambda = std::max(lambda / 3.0, 1e-7);
      accepted = true;
      if (negligible) it = round.iterations;
    }
    if (!accepted) break;
  }
  return acc;
}

// Only along directions this round's frames determine (looser than the final verdict: early
// rounds just must not wander along directions their short windows cannot see). Noise test only:
// the leverage test guards the final result against INS errors, while a round must be free to
// move every DOF its frames see, however slightly.
std::vector<int> round_free_dofs(const Accum& acc, const ObservabilityConfig& config, bool tz_free) {
  ObservabilityConfig loose = config;
  loose.max_stddev_trans_m *= 5.0;
  loose.max_stddev_rot_deg *= 5.0;
  const double sigma0 = std::sqrt(acc.weighted_sq / std::max(acc.weighted_n, 1.0));
  const DofVerdict verdict = assess_observability(acc.H, sigma0, loose);
  std::vector<int> free;
  for (int i = 0; i < 6; ++i)
    if (verdict.determined[i] && (i != 2 || tz_free)) free.push_back(i);
  return free;
}

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace

RoughResult calibrate_rough(const FrameStore& store, const FrameGroups& groups, const Iso3& T_ins_lidar_init,
                            double time_offset_s, const RoughConfig& config,
                            const std::function<void(double fraction)>& progress) {
  const auto start = std::chrono::steady_clock::now();
  auto report = [&](double f) {
    if (progress) progress(f);
  };
  report(0.0);  // the step starts now: loading its frames is part of it
  RoughResult result;
  result.T_ins_lidar = T_ins_lidar_init;
  auto finish = [&](StageStatus status, std::string message) {
    result.outcome.status = status;
    result.outcome.message = std::move(message);
    result.outcome.determined = result.observability.determined;
    result.outcome.stddev = result.observability.stddev;
    result.outcome.wall_time_s = seconds_since(start);
    report(1.0);
    return result;
  };
  std::size_t n_frames = 0;
  for (const auto& g : groups) n_frames += g.size();
  if (n_frames < 2) {
    result.observability = assess_observability(Mat6::Zero(), 1.0, config.observability);
    result.observability.explanation =
        "undetermined: tx ty tz roll pitch yaw. The vehicle does not move during the frames the poses "
        "cover (standing still): every extrinsic lines the sweeps up equally well.";
    return finish(StageStatus::kUndetermined, result.observability.explanation);
  }

  const RoughFrames frames = load_rough_frames(store, groups, config);
  result.frames_used = frames.loaded;
  result.load_time_s = seconds_since(start);
  report(0.3);

  Iso3 T_ins_lidar = T_ins_lidar_init;
  Accum last;
  Problem problem;
  auto run_round = [&](int index, const RoughRound& round, bool tz_free) {
    const auto round_start = std::chrono::steady_clock::now();
    RoundLog log;
    log.round = index;
    problem = build_round_problem(frames, store.poses(), T_ins_lidar, time_offset_s, round, config, &log.windows);
    log.planes = problem.planes();
    log.residuals = problem.residuals;
    log.build_s = seconds_since(round_start);
    log.T_ins_lidar = T_ins_lidar;
    if (problem.planes() > 0) {
      const auto solve_start = std::chrono::steady_clock::now();
      const Accum acc = evaluate(problem, T_ins_lidar, round.robust_scale_m, true);
      if (result.convergence.empty()) result.cost_before = acc.cost;
      last = solve_round(problem, round, round_free_dofs(acc, config.observability, tz_free), acc, T_ins_lidar);
      log.T_ins_lidar = T_ins_lidar;
      log.cost = result.cost_after = last.cost;
      log.solve_s = seconds_since(solve_start);
    }
    result.convergence.push_back(log);
  };
  const int n_rounds = static_cast<int>(config.rounds.size());
  for (int r = 0; r < n_rounds; ++r) {
    run_round(r, config.rounds[r], false);
    report(0.3 + 0.65 * (r + 1) / std::max(1, n_rounds));
  }
  auto verdict = [&] {
    const double sigma = std::sqrt(last.weighted_sq / std::max(last.weighted_n, 1.0));
    return assess_observability(last.H, sigma, last.weighted_n, config.observability);
  };
  result.observability = verdict();
  if (!config.always_fix_tz && result.observability.determined[2] && n_rounds > 0) {
    run_round(n_rounds, config.rounds.back(), true);
    result.tz_estimated = true;
    result.observability = verdict();
  }
  result.T_ins_lidar = T_ins_lidar;
  result.information = last.H;
  result.residual_sigma_m = std::sqrt(last.weighted_sq / std::max(last.weighted_n, 1.0));
  result.planes = problem.planes();
  result.residuals = problem.residuals;
  result.rounds = static_cast<int>(result.convergence.size());
  const auto reason = unobservable_reason(result.observability);
  return finish(reason ? StageStatus::kUndetermined : StageStatus::kOk, reason.value_or(""));
}

}  // namespace insalign
