#include "core/pose_stream.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

namespace insalign {

PoseStream::PoseStream(std::vector<StampedPose> poses) : poses_(std::move(poses)) {
  for (std::size_t i = 0; i < poses_.size(); ++i) {
    if (!std::isfinite(poses_[i].t_s)) {
      throw std::invalid_argument("pose " + std::to_string(i) + " has a non-finite time");
    }
    if (i > 0 && !(poses_[i].t_s > poses_[i - 1].t_s)) {
      throw std::invalid_argument("pose times must be strictly increasing: pose " + std::to_string(i) +
                                  " at t=" + std::to_string(poses_[i].t_s) + " s follows t=" +
                                  std::to_string(poses_[i - 1].t_s) + " s");
    }
  }
}

Iso3 PoseStream::T_world_ins(double t_s) const {
  if (!covers(t_s)) {
    const std::string range =
        poses_.empty() ? "an empty pose stream"
                       : "poses covering [" + std::to_string(t_begin()) + ", " + std::to_string(t_end()) + "] s";
    throw OutOfRangeError("time " + std::to_string(t_s) + " s is outside " + range);
  }
  if (poses_.size() == 1) return poses_.front().T_world_ins;
  // Segment [i, i+1] containing t.
  auto it = std::upper_bound(poses_.begin(), poses_.end(), t_s,
                             [](double t, const StampedPose& p) { return t < p.t_s; });
  std::size_t i1 = std::min<std::size_t>(std::max<std::ptrdiff_t>(it - poses_.begin(), 1), poses_.size() - 1);
  std::size_t i0 = i1 - 1;
  const StampedPose& a = poses_[i0];
  const StampedPose& b = poses_[i1];
  const double h = b.t_s - a.t_s;
  const double s = (t_s - a.t_s) / h;

  Iso3 out = Iso3::Identity();
  const Eigen::Quaterniond qa(a.T_world_ins.linear());
  const Eigen::Quaterniond qb(b.T_world_ins.linear());
  out.linear() = qa.slerp(s, qb).normalized().toRotationMatrix();

  // Cubic Hermite on translation with finite-difference tangents (non-uniform Catmull-Rom).
  const Vec3 pa = a.T_world_ins.translation();
  const Vec3 pb = b.T_world_ins.translation();
  const auto tangent = [&](std::size_t k) -> Vec3 {
    const std::size_t lo = k == 0 ? 0 : k - 1;
    const std::size_t hi = std::min(k + 1, poses_.size() - 1);
    return (poses_[hi].T_world_ins.translation() - poses_[lo].T_world_ins.translation()) /
           (poses_[hi].t_s - poses_[lo].t_s);
  };
  const Vec3 va = tangent(i0) * h;
  const Vec3 vb = tangent(i1) * h;
  const double s2 = s * s, s3 = s2 * s;
  out.translation() = (2 * s3 - 3 * s2 + 1) * pa + (s3 - 2 * s2 + s) * va + (-2 * s3 + 3 * s2) * pb + (s3 - s2) * vb;
  return out;
}

double rotation_angle_deg(const PoseStream& poses, double t0_s, double t1_s) {
  if (!poses.covers(t0_s) || !poses.covers(t1_s)) return std::numeric_limits<double>::quiet_NaN();
  const Mat3 R = poses.T_world_ins(t0_s).linear().transpose() * poses.T_world_ins(t1_s).linear();
  return Eigen::AngleAxisd(R).angle() * kDegPerRad;
}

}  // namespace insalign
