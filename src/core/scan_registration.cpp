#include "core/scan_registration.hpp"

#include "core/voxel_grid.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numeric>
#include <unordered_map>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <Eigen/Eigenvalues>
#include <nanoflann.hpp>

namespace insalign {
namespace {

struct CloudAdaptor {
  const std::vector<Vec3>* points;
  std::size_t kdtree_get_point_count() const { return points->size(); }
  double kdtree_get_pt(std::size_t i, std::size_t dim) const { return (*points)[i][static_cast<int>(dim)]; }
  template <class BBox>
  bool kdtree_get_bbox(BBox&) const { return false; }
};
using KdTree = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<double, CloudAdaptor>,
                                                   CloudAdaptor, 3, std::uint32_t>;

}  // namespace

struct PlaneTarget::Tree {
  explicit Tree(const std::vector<Vec3>& points) : adaptor{&points}, index(3, adaptor, nanoflann::KDTreeSingleIndexAdaptorParams(10)) {}
  CloudAdaptor adaptor;
  KdTree index;
};

PlaneTarget::PlaneTarget(std::vector<Vec3> points, int normal_neighbours, double max_plane_thickness_m, NormalFit fit)
    : points_(std::move(points)),
      neighbours_(static_cast<std::size_t>(std::max(normal_neighbours, 3))),
      max_thickness_m_(max_plane_thickness_m),
      normals_(points_.size(), Vec3::Zero()),
      fitted_(points_.size(), 0),
      tree_(std::make_unique<Tree>(points_)) {
  if (fit != NormalFit::kUpFront) return;
  std::vector<std::uint32_t> all(points_.size());
  std::iota(all.begin(), all.end(), std::uint32_t{0});
  fit_normals(all);
}

PlaneTarget::~PlaneTarget() = default;
PlaneTarget::PlaneTarget(PlaneTarget&&) noexcept = default;
PlaneTarget& PlaneTarget::operator=(PlaneTarget&&) noexcept = default;

void PlaneTarget::fit_normals(const std::vector<std::uint32_t>& indices) const {
  std::vector<std::uint32_t> todo;
  for (std::uint32_t i : indices)
    if (i < points_.size() && !fitted_[i]) todo.push_back(i);
  std::sort(todo.begin(), todo.end());
  todo.erase(std::unique(todo.begin(), todo.end()), todo.end());
  // Distinct points write distinct elements; each task its own search scratch.
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, todo.size(), 256), [&](const tbb::blocked_range<std::size_t>& r) {
    std::vector<std::uint32_t> idx;
    std::vector<double> d2;
    for (std::size_t k = r.begin(); k < r.end(); ++k) fit_normal(todo[k], idx, d2);
  });
}

void PlaneTarget::fit_normal(std::size_t i, std::vector<std::uint32_t>& idx, std::vector<double>& d2) const {
  fitted_[i] = 1;
  idx.resize(neighbours_), d2.resize(neighbours_);
  const std::size_t found = tree_->index.knnSearch(points_[i].data(), neighbours_, idx.data(), d2.data());
  if (found < 3) return;
  Vec3 mean = Vec3::Zero();
  for (std::size_t j = 0; j < found; ++j) mean += points_[idx[j]];
  mean /= static_cast<double>(found);
  Mat3 cov = Mat3::Zero();
  for (std::size_t j = 0; j < found; ++j) {
    const Vec3 d = points_[idx[j]] - mean;
    cov += d * d.transpose();
  }
  cov /= static_cast<double>(found);
  Eigen::SelfAdjointEigenSolver<Mat3> eig(cov);
  if (std::sqrt(std::max(eig.eigenvalues()(0), 0.0)) > max_thickness_m_) return;
  // A patch that is a line (one dominant direction) has no reliable normal.
  if (eig.eigenvalues()(1) < 1e-4) return;
  normals_[i] = eig.eigenvectors().col(0);
}

namespace {
// Squared distance summed as nanoflann sums it, so that a gate test here agrees with its search.
double distance2(const Vec3& a, const Vec3& b) {
  double d2 = 0.0;
  for (int i = 0; i < 3; ++i) d2 += (a[i] - b[i]) * (a[i] - b[i]);
  return d2;
}
}  // namespace

std::optional<std::size_t> PlaneTarget::nearest(const Vec3& p, double gate_m, NearestMemo& memo) const {
  if (points_.empty()) return std::nullopt;
  const double gate2 = gate_m * gate_m;
  if (!std::isnan(memo.p_searched.x())) {
    // Every target point but memo.index is at least `clear` from p (triangle inequality; the
    // margin covers rounding).
    const double clear = memo.clear_m - (p - memo.p_searched).norm() - 1e-9;
    if (memo.index == NearestMemo::kNoIndex) {
      if (gate_m <= clear) return std::nullopt;
    } else {
      const double d2 = distance2(points_[memo.index], p);
      if (std::sqrt(d2) < clear) return d2 < gate2 ? std::optional<std::size_t>(memo.index) : std::nullopt;
    }
  }
  // The two nearest within the gate: the second bounds how far p may move before the next search.
  // The gate as the initial worst distance: branches beyond it are never searched.
  std::uint32_t index[2] = {NearestMemo::kNoIndex, NearestMemo::kNoIndex};
  double d2[2] = {0.0, 0.0};
  nanoflann::KNNResultSet<double, std::uint32_t> found(2);
  found.init(index, d2);
  d2[1] = gate2;
  tree_->index.findNeighbors(found, p.data(), nanoflann::SearchParams());
  memo.p_searched = p;
  memo.index = found.size() >= 1 ? index[0] : NearestMemo::kNoIndex;
  memo.clear_m = found.size() == 2 ? std::sqrt(d2[1]) : gate_m;
  if (found.size() < 1) return std::nullopt;
  return index[0];
}

PointToPlaneSystem point_to_plane_system(const std::vector<Vec3>& p_source, const std::vector<Vec3>& q_target,
                                         const std::vector<Vec3>& n_target, const Iso3& T_target_source,
                                         double huber_delta_m) {
  PointToPlaneSystem sys;
  for (std::size_t i = 0; i < p_source.size(); ++i) {
    const Vec3 p = T_target_source * p_source[i];
    const Vec3& n = n_target[i];
    const double r = n.dot(p - q_target[i]);
    // Left perturbation T <- exp([rho, omega]) T: dp = rho + omega x p.
    Vec6 J;
    J << n, p.cross(n);
    const double w = std::abs(r) <= huber_delta_m ? 1.0 : huber_delta_m / std::abs(r);
    sys.hessian += w * J * J.transpose();
    sys.gradient += w * J * r;
    sys.cost += 0.5 * w * r * r;
    sys.sum_sq_m2 += r * r;
  }
  return sys;
}

ScanRegistrationResult register_scans(const std::vector<Vec3>& target, const std::vector<Vec3>& source,
                                      const Iso3& T_target_source_init, const ScanRegistrationConfig& config) {
  ScanRegistrationResult result;
  result.T_target_source = T_target_source_init;
  if (target.size() < 10 || source.empty()) return result;

  const PlaneTarget planes(target, config.normal_neighbours, config.max_plane_thickness_m, NormalFit::kOnDemand);
  std::vector<NearestMemo> memo(source.size());  // each source point's last search

  const int n_iter = std::max(config.max_iterations, 1);
  const double shrink = std::pow(config.max_corr_dist_end_m / config.max_corr_dist_start_m,
                                 1.0 / std::max(n_iter / 2 - 1, 1));
  double gate_m = config.max_corr_dist_start_m;
  Iso3 T = T_target_source_init;
  Mat6 H_last = Mat6::Zero();
  for (int iter = 0; iter < n_iter; ++iter) {
    // Associate each source point with its nearest target point inside the gate.
    std::vector<Vec3> p_source, q_target, n_target;
    for (std::size_t i = 0; i < source.size(); ++i) {
      const Vec3& p_s = source[i];
      const std::optional<std::size_t> j = planes.nearest(T * p_s, gate_m, memo[i]);
      if (!j || planes.normal(*j).isZero()) continue;
      p_source.push_back(p_s);
      q_target.push_back(planes.point(*j));
      n_target.push_back(planes.normal(*j));
    }
    const PointToPlaneSystem sys = point_to_plane_system(p_source, q_target, n_target, T, config.huber_delta_m);
    const Mat6& H = sys.hessian;
    const Vec6& g = sys.gradient;
    const int inliers = static_cast<int>(p_source.size());
    const double sum_r2 = sys.sum_sq_m2;
    result.iterations = iter + 1;
    result.num_inliers = inliers;
    result.rms_m = inliers > 0 ? std::sqrt(sum_r2 / inliers) : 0.0;
    result.inlier_ratio = static_cast<double>(inliers) / static_cast<double>(source.size());
    H_last = H;
    if (inliers < std::max(config.min_inliers, 6)) return result;
    const Vec6 delta = -(H + 1e-6 * Mat6::Identity()).ldlt().solve(g);
    Iso3 step = Iso3::Identity();
    step.linear() = so3_exp(delta.tail<3>());
    step.translation() = delta.head<3>();
    T = step * T;
    T.linear() = nearest_rotation(T.linear());
    gate_m = std::max(gate_m * shrink, config.max_corr_dist_end_m);
    if (delta.head<3>().norm() < config.converged_step_m && delta.tail<3>().norm() < config.converged_step_m &&
        gate_m <= config.max_corr_dist_end_m) {
      result.converged = true;
      break;
    }
  }
  // Running out of iterations at the final gate with small steps still counts as converged.
  if (!result.converged && gate_m <= config.max_corr_dist_end_m && result.num_inliers >= config.min_inliers)
    result.converged = true;
  result.T_target_source = T;
  Eigen::SelfAdjointEigenSolver<Mat6> eig(H_last / std::max(result.num_inliers, 1));
  result.min_information = eig.eigenvalues()(0);
  return result;
}

}  // namespace insalign
