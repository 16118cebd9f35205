#include "core/scan_registration.hpp"

#include "core/voxel_grid.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <unordered_map>

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


// Normal of each target point from its k nearest neighbours; zero where the patch is not planar.
std::vector<Vec3> target_normals(const std::vector<Vec3>& target, const KdTree& tree, const ScanRegistrationConfig& config) {
  std::vector<Vec3> normals(target.size(), Vec3::Zero());
  const int k = std::max(config.normal_neighbours, 3);
  std::vector<std::uint32_t> idx(k);
  std::vector<double> d2(k);
  for (std::size_t i = 0; i < target.size(); ++i) {
    const std::size_t found = tree.knnSearch(target[i].data(), k, idx.data(), d2.data());
    if (found < 3) continue;
    Vec3 mean = Vec3::Zero();
    for (std::size_t j = 0; j < found; ++j) mean += target[idx[j]];
    mean /= static_cast<double>(found);
    Mat3 cov = Mat3::Zero();
    for (std::size_t j = 0; j < found; ++j) {
      const Vec3 d = target[idx[j]] - mean;
      cov += d * d.transpose();
    }
    cov /= static_cast<double>(found);
    Eigen::SelfAdjointEigenSolver<Mat3> eig(cov);
    if (std::sqrt(std::max(eig.eigenvalues()(0), 0.0)) > config.max_plane_thickness_m) continue;
    // A patch that is a line (one dominant direction) has no reliable normal.
    if (eig.eigenvalues()(1) < 1e-4) continue;
    normals[i] = eig.eigenvectors().col(0);
  }
  return normals;
}

}  // namespace

ScanRegistrationResult register_scans(const std::vector<Vec3>& target, const std::vector<Vec3>& source,
                                      const Iso3& T_target_source_init, const ScanRegistrationConfig& config) {
  ScanRegistrationResult result;
  result.T_target_source = T_target_source_init;
  if (target.size() < 10 || source.empty()) return result;

  CloudAdaptor adaptor{&target};
  KdTree tree(3, adaptor, nanoflann::KDTreeSingleIndexAdaptorParams(10));
  const std::vector<Vec3> normals = target_normals(target, tree, config);

  const int n_iter = std::max(config.max_iterations, 1);
  const double shrink = std::pow(config.max_corr_dist_end_m / config.max_corr_dist_start_m,
                                 1.0 / std::max(n_iter / 2 - 1, 1));
  double gate_m = config.max_corr_dist_start_m;
  Iso3 T = T_target_source_init;
  Mat6 H_last = Mat6::Zero();
  for (int iter = 0; iter < n_iter; ++iter) {
    Mat6 H = Mat6::Zero();
    Vec6 g = Vec6::Zero();
    double sum_r2 = 0.0;
    int inliers = 0;
    for (const Vec3& p_s : source) {
      const Vec3 p = T * p_s;
      std::uint32_t j = 0;
      double d2 = 0.0;
      if (tree.knnSearch(p.data(), 1, &j, &d2) < 1 || d2 > gate_m * gate_m) continue;
      const Vec3& n = normals[j];
      if (n.isZero()) continue;
      const double r = n.dot(p - target[j]);
      // Left perturbation T <- exp([rho, omega]) T: dp = rho + omega x p.
      Vec6 J;
      J << n, p.cross(n);
      const double w = std::abs(r) <= config.huber_delta_m ? 1.0 : config.huber_delta_m / std::abs(r);
      H += w * J * J.transpose();
      g += w * J * r;
      sum_r2 += r * r;
      ++inliers;
    }
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
