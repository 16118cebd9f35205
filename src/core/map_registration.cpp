#include "core/map_registration.hpp"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>

#include "core/stitch.hpp"

namespace insalign {
namespace {

// One sweep's points in the LiDAR frame, each with the INS pose at its own time (the motion
// within the sweep is exact for any extrinsic).
struct PlacedSweep {
  std::vector<Iso3> T_world_ins;
  std::vector<Vec3> p_lidar;
};

// The Gauss-Newton system of every sweep's point-to-plane residuals
// r = n . (T_world_ins exp([rho; omega]) T_ins_lidar p - q), perturbation in the INS frame.
struct System {
  Mat6 H = Mat6::Zero();
  Vec6 g = Vec6::Zero();
  MapFit fit;
  double sum_sq = 0.0;
  void add(const System& o) {
    H += o.H, g += o.g, sum_sq += o.sum_sq;
    fit.points += o.fit.points, fit.inliers += o.fit.inliers;
  }
};

// Each point's last nearest-neighbour search, per sweep (PlaneTarget::nearest).
using LastMatches = std::vector<std::vector<NearestMemo>>;

// Each point's nearest map point within the gate (NearestMemo::kNoIndex: none): the search only
// reads the map, so the sweeps search in parallel.
std::vector<std::uint32_t> sweep_matches(const PlacedSweep& s, const PlaneTarget& map, const Iso3& T_ins_lidar,
                                         double gate_m, std::vector<NearestMemo>& last) {
  std::vector<std::uint32_t> match(s.p_lidar.size(), NearestMemo::kNoIndex);
  last.resize(s.p_lidar.size());
  for (std::size_t i = 0; i < s.p_lidar.size(); ++i) {
    const std::optional<std::size_t> j = map.nearest(s.T_world_ins[i] * (T_ins_lidar * s.p_lidar[i]), gate_m, last[i]);
    if (j) match[i] = static_cast<std::uint32_t>(*j);
  }
  return match;
}

System sweep_system(const PlacedSweep& s, const PlaneTarget& map, const Iso3& T_ins_lidar,
                    const std::vector<std::uint32_t>& match, double huber_m) {
  System sys;
  for (std::size_t i = 0; i < s.p_lidar.size(); ++i) {
    const Vec3 p_ins = T_ins_lidar * s.p_lidar[i];
    const Vec3 p_world = s.T_world_ins[i] * p_ins;
    ++sys.fit.points;
    if (match[i] == NearestMemo::kNoIndex || map.normal(match[i]).isZero()) continue;
    const std::size_t j = match[i];
    const Vec3 n_ins = s.T_world_ins[i].linear().transpose() * map.normal(j);
    const double r = map.normal(j).dot(p_world - map.point(j));
    Vec6 J;
    J << n_ins, p_ins.cross(n_ins);
    const double w = std::abs(r) <= huber_m ? 1.0 : huber_m / std::abs(r);
    sys.H += w * J * J.transpose();
    sys.g += w * J * r;
    sys.sum_sq += r * r;
    ++sys.fit.inliers;
  }
  return sys;
}

// The map's normals are fitted only where a sweep point lands (not every map point is met), in
// parallel, between the parallel searches and the parallel sums (fit_normals).
System total_system(const std::vector<PlacedSweep>& sweeps, const PlaneTarget& map, const Iso3& T_ins_lidar,
                    double gate_m, double huber_m, LastMatches& last) {
  std::vector<std::vector<std::uint32_t>> match(sweeps.size());
  last.resize(sweeps.size());
  tbb::parallel_for(std::size_t{0}, sweeps.size(),
                    [&](std::size_t k) { match[k] = sweep_matches(sweeps[k], map, T_ins_lidar, gate_m, last[k]); });
  std::vector<std::uint32_t> all;
  for (const std::vector<std::uint32_t>& m : match) all.insert(all.end(), m.begin(), m.end());
  map.fit_normals(all);
  std::vector<System> per(sweeps.size());
  tbb::parallel_for(std::size_t{0}, sweeps.size(),
                    [&](std::size_t k) { per[k] = sweep_system(sweeps[k], map, T_ins_lidar, match[k], huber_m); });
  System sum;
  for (const System& s : per) sum.add(s);
  sum.fit.rms_m = sum.fit.inliers ? std::sqrt(sum.sum_sq / double(sum.fit.inliers)) : 0.0;
  return sum;
}

}  // namespace

struct MapRegistration::Sweeps {
  std::vector<PlacedSweep> all;
  std::vector<PlacedSweep> coarse;  // every coarse_stride-th point of each
};

std::shared_ptr<const PlaneTarget> map_target(const std::vector<Vec3f>& map_world, const MapRegistrationConfig& config) {
  std::vector<Vec3> target(map_world.size());
  std::transform(map_world.begin(), map_world.end(), target.begin(), [](const Vec3f& p) { return p.cast<double>(); });
  return std::make_shared<const PlaneTarget>(std::move(target), config.normal_neighbours, config.max_plane_thickness_m,
                                             NormalFit::kOnDemand);
}

MapRegistration::MapRegistration(const FrameStore& store, const std::vector<Vec3f>& map_world, double time_offset_s,
                                 const MapRegistrationConfig& config)
    : MapRegistration(store, map_target(map_world, config), time_offset_s, config) {}

MapRegistration::MapRegistration(const FrameStore& store, std::shared_ptr<const PlaneTarget> map, double time_offset_s,
                                 const MapRegistrationConfig& config)
    : config_(config), map_(std::move(map)) {
  const std::vector<Sweep> thinned = store.thinned(spread_frames(store, config.frames, time_offset_s), config.filter);
  auto sweeps = std::make_unique<Sweeps>();
  sweeps->all.resize(thinned.size());
  tbb::parallel_for(std::size_t{0}, thinned.size(), [&](std::size_t k) {
    const Sweep& sweep = thinned[k];
    if (!sweep_covered(store.poses(), sweep, time_offset_s)) return;
    PlacedSweep& s = sweeps->all[k];
    for (std::size_t i = 0; i < sweep.size(); ++i) {
      const double dt_s = sweep.has_time() ? sweep.dt_s[i] : 0.0;
      s.T_world_ins.push_back(store.poses().T_world_ins(sweep.t_end_s + dt_s + time_offset_s));
      s.p_lidar.push_back(sweep.p_lidar[i].cast<double>());
    }
  });
  const std::size_t stride = std::max<std::size_t>(config.coarse_stride, 1);
  for (const PlacedSweep& s : sweeps->all) {
    PlacedSweep& c = sweeps->coarse.emplace_back();
    for (std::size_t i = 0; i < s.p_lidar.size(); i += stride)
      c.T_world_ins.push_back(s.T_world_ins[i]), c.p_lidar.push_back(s.p_lidar[i]);
  }
  sweeps_ = std::move(sweeps);
}

MapRegistration::~MapRegistration() = default;

MapFit MapRegistration::fit(const Iso3& T_ins_lidar) const {
  LastMatches none;
  return total_system(sweeps_->all, *map_, T_ins_lidar, config_.gate_end_m, config_.huber_m, none).fit;
}

MapRegistrationResult MapRegistration::solve(const Iso3& T_ins_lidar_start) const {
  MapRegistrationResult result;
  LastMatches last, last_coarse;
  const auto fit_at = [&](const Iso3& T) {
    return total_system(sweeps_->all, *map_, T, config_.gate_end_m, config_.huber_m, last).fit;
  };
  result.start = fit_at(T_ins_lidar_start);
  const int n_iter = std::max(config_.iterations, 1);
  const double shrink = std::pow(config_.gate_end_m / config_.gate_start_m, 1.0 / std::max(n_iter / 2 - 1, 1));
  double gate_m = config_.gate_start_m;
  double last_rms_m = -1.0;  // at the final gate
  Iso3 T = T_ins_lidar_start;
  for (int iter = 0; iter < n_iter; ++iter) {
    // While the gate still shrinks the start may be decimetres off: a sample of the points finds
    // the basin; the final gate's iterations take every point.
    const bool coarse = gate_m > config_.gate_end_m;
    const System sys = total_system(coarse ? sweeps_->coarse : sweeps_->all, *map_, T, gate_m, config_.huber_m,
                                    coarse ? last_coarse : last);
    result.iterations = iter + 1;
    const std::size_t stride = coarse ? std::max<std::size_t>(config_.coarse_stride, 1) : 1;
    if (sys.fit.inliers * stride < std::max<std::size_t>(config_.min_inliers, 6)) break;
    const Vec6 delta = -(sys.H + 1e-6 * Mat6::Identity()).ldlt().solve(sys.g);
    Iso3 step = Iso3::Identity();
    step.linear() = so3_exp(delta.tail<3>());
    step.translation() = delta.head<3>();
    T = step * T;  // T_world_ins exp(delta) T_ins_lidar: the perturbation in the INS frame
    T.linear() = nearest_rotation(T.linear());
    const bool final_gate = gate_m <= config_.gate_end_m;
    gate_m = std::max(gate_m * shrink, config_.gate_end_m);
    if (final_gate && delta.head<3>().norm() < config_.converged_step && delta.tail<3>().norm() < config_.converged_step)
      break;
    if (!final_gate) continue;
    const double rms_m = std::sqrt(sys.sum_sq / double(sys.fit.inliers));
    if (last_rms_m > 0.0 && last_rms_m - rms_m < config_.converged_rms_fraction * last_rms_m) break;
    last_rms_m = rms_m;
  }
  result.T_ins_lidar = T;
  result.end = fit_at(T);
  result.converged = result.end.inliers >= config_.min_inliers;
  return result;
}

}  // namespace insalign
