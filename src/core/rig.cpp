#include "core/rig.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numeric>

#include "core/errors.hpp"
#include "core/stitch.hpp"
#include "core/voxel_grid.hpp"

namespace insalign {
namespace {

using Mat12 = Eigen::Matrix<double, 12, 12>;
constexpr double kUnknownSigma = 1e3;  // stands in for +inf in the propagation (m, rad)

double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

std::string prefix(const std::string& name) { return "LiDAR '" + name + "': "; }

Mat3 skew(const Vec3& v) {
  Mat3 m;
  m << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return m;
}

// The per-LiDAR progress: "<name>: <step>".
PipelineProgress lidar_progress(const PipelineProgress& progress, const std::string& name) {
  return [&progress, name](std::string_view step, double f) {
    if (progress) progress(name + ": " + std::string(step), f);
  };
}

// Steps 0-2 of every LiDAR alone; a LiDAR whose start cannot be found stops the run by name.
std::vector<FrameGroups> start_all(const std::vector<FrameStore>& stores, const PipelineConfig& config,
                                   const PipelineProgress& progress, RigResult& rig) {
  std::vector<FrameGroups> groups;
  for (std::size_t l = 0; l < stores.size(); ++l) {
    RigLidar& lidar = rig.lidars[l];
    try {
      groups.push_back(run_start(stores[l], config, lidar_progress(progress, lidar.name), lidar.result, true));
    } catch (const UnobservableError& e) {
      throw UnobservableError(prefix(lidar.name) + e.what());
    }
    lidar.determined_alone = lidar.result.rough.outcome.determined;
  }
  return groups;
}

std::vector<std::uint64_t> voxel_keys(const std::vector<Vec3f>& p_world, double voxel_m) {
  std::vector<std::uint64_t> keys;
  keys.reserve(p_world.size());
  for (const Vec3f& p : p_world) keys.push_back(voxel_key(p, 1.0 / voxel_m));
  std::sort(keys.begin(), keys.end());
  keys.erase(std::unique(keys.begin(), keys.end()), keys.end());
  return keys;
}

double keys_overlap(const std::vector<std::uint64_t>& a, const std::vector<std::uint64_t>& b) {
  if (a.empty() || b.empty()) return 0.0;
  std::size_t shared = 0;
  for (std::size_t i = 0, j = 0; i < a.size() && j < b.size();) {
    if (a[i] == b[j]) ++shared, ++i, ++j;
    else if (a[i] < b[j]) ++i;
    else ++j;
  }
  return static_cast<double>(shared) / static_cast<double>(std::min(a.size(), b.size()));
}

// Each LiDAR's map at its stage-1 extrinsic; overlap[a][b] as JointConfig measures it.
std::vector<std::vector<double>> overlap_matrix(const std::vector<FrameStore>& stores, const RigResult& rig,
                                                const JointConfig& joint) {
  std::vector<std::vector<std::uint64_t>> keys;
  for (std::size_t l = 0; l < stores.size(); ++l) {
    const CalibrationResult& r = rig.lidars[l].result;
    const std::vector<std::size_t> frames = spread_frames(stores[l], joint.overlap_frames, 0.0);
    keys.push_back(voxel_keys(stitch_map(stores[l], frames, r.T_ins_lidar, 0.0, 0.0), joint.overlap_voxel_m));
  }
  std::vector<std::vector<double>> overlap(stores.size(), std::vector<double>(stores.size(), 1.0));
  for (std::size_t a = 0; a < stores.size(); ++a)
    for (std::size_t b = a + 1; b < stores.size(); ++b) overlap[a][b] = overlap[b][a] = keys_overlap(keys[a], keys[b]);
  return overlap;
}

// Connected components of "overlaps at least min_overlap" (every LiDAR alone when disabled).
std::vector<std::vector<std::size_t>> overlap_groups(const std::vector<std::vector<double>>& overlap,
                                                     const JointConfig& joint) {
  const std::size_t n = overlap.size();
  std::vector<std::size_t> root(n);
  std::iota(root.begin(), root.end(), std::size_t{0});
  const auto find = [&](std::size_t i) {
    while (root[i] != i) i = root[i] = root[root[i]];
    return i;
  };
  for (std::size_t a = 0; a < n && joint.enabled; ++a)
    for (std::size_t b = a + 1; b < n; ++b)
      if (overlap[a][b] >= joint.min_overlap) root[find(b)] = find(a);
  std::vector<std::vector<std::size_t>> groups;
  std::vector<std::size_t> group_of(n, n);
  for (std::size_t l = 0; l < n; ++l) {
    const std::size_t r = find(l);
    if (group_of[r] == n) {
      group_of[r] = groups.size();
      groups.emplace_back();
    }
    groups[group_of[r]].push_back(l);
  }
  return groups;
}

// A joint group's inputs: stage 2 starts from stage 1 with tz fixed by an early stage 3, as
// run_calibration does (a wrong tz biases the horizontal lever arm).
std::vector<RefineLidar> group_inputs(const std::vector<FrameStore>& stores, const std::vector<std::size_t>& members,
                                      const PipelineConfig& config, RigResult& rig) {
  std::vector<RefineLidar> in;
  const double margin = config.refine.estimate_time_offset ? config.refine.time_offset_range_s : 0.0;
  for (std::size_t l : members) {
    CalibrationResult& r = rig.lidars[l].result;
    const ZResult early_z = correct_z(stores[l], r.T_ins_lidar, r.time_offset_s, config.ins_height_m, config.z);
    if (early_z.determined()) r.T_ins_lidar = early_z.T_ins_lidar;
    in.push_back({rig.lidars[l].name, &stores[l], refine_frames(stores[l], config.refine, 0.0, margin), r.T_ins_lidar,
                  r.time_offset_s, true});
  }
  return in;
}

// A DOF is determined jointly when its marginal stddev passes stage 1's noise test.
bool passes(int dof, double stddev, const ObservabilityConfig& c) {
  return dof < 3 ? stddev < c.max_stddev_trans_m : stddev < c.max_stddev_rot_deg * kRadPerDeg;
}

// The joint result into each member's CalibrationResult, with its verdicts.
void take_joint(const JointRefineResult& joint, const std::vector<std::size_t>& members, const PipelineConfig& config,
                RigResult& rig) {
  for (std::size_t k = 0; k < members.size(); ++k) {
    RigLidar& lidar = rig.lidars[members[k]];
    CalibrationResult& r = lidar.result;
    r.refine = joint.lidars[k];
    r.T_ins_lidar = r.refine->T_ins_lidar;
    r.time_offset_s = r.refine->time_offset_s;
    r.time_offset_stddev_s = r.refine->time_offset_stddev_s;
    lidar.formal_stddev = r.refine->outcome.stddev;
    for (int i : {0, 1, 3, 4, 5}) {
      const double sd = r.refine->outcome.stddev[i];
      const bool joint_ok = members.size() > 1 && passes(i, sd, config.rough.observability);
      r.determined[i] = lidar.determined_alone[i] || joint_ok;
      if (std::isfinite(sd) && r.determined[i]) r.stddev[i] = sd;
      if (!r.determined[i]) r.stddev[i] = std::numeric_limits<double>::infinity();
    }
  }
}

// The names and reasons of LiDARs with a DOF other than tz undetermined even jointly.
std::string undetermined_message(const RigResult& rig) {
  std::string out;
  for (const RigLidar& lidar : rig.lidars) {
    std::vector<std::string> dofs;
    for (int i : {0, 1, 3, 4, 5})
      if (!lidar.result.determined[i]) dofs.push_back(kDofNames[i]);
    if (dofs.empty()) continue;
    const RoughResult& rough = lidar.result.rough;
    out += fmt::format("{}{} not determined{} (alone: {}). ", prefix(lidar.name), fmt::join(dofs, ", "),
                       lidar.joint_with.empty() ? "" : " even jointly with " + fmt::format("{}", fmt::join(lidar.joint_with, ", ")),
                       rough.outcome.message.empty() ? rough.observability.explanation : rough.outcome.message);
  }
  return out;
}

// Stage 2 of every group; a LiDAR of a group of one is refine_checked's problem exactly.
std::vector<JointRefineResult> refine_groups(const std::vector<FrameStore>& stores,
                                             const std::vector<std::vector<std::size_t>>& groups,
                                             const PipelineConfig& config, const PipelineProgress& progress,
                                             std::vector<std::vector<RefineLidar>>& inputs, RigResult& rig) {
  std::vector<JointRefineResult> out;
  for (std::size_t g = 0; g < groups.size(); ++g) {
    inputs.push_back(group_inputs(stores, groups[g], config, rig));
    double max_speed_mps = 0.0;
    for (std::size_t l : groups[g]) max_speed_mps = std::max(max_speed_mps, rig.lidars[l].result.motion.max_speed_mps);
    std::vector<std::string> warnings;
    const std::string step = groups[g].size() > 1 ? "joint refine" : rig.lidars[groups[g].front()].name + ": refine";
    const auto report = [&](double f) { if (progress) progress(step, f); };
    // The lever-arm check assumes stage 1 within a few centimetres; a LiDAR that stage 1 could
    // not determine alone starts further out: one unchecked joint pass first, then the checked
    // one from there (which also re-finds the planes on a map that is already sharp).
    bool weak = false;
    for (std::size_t l : groups[g]) weak = weak || !rig.lidars[l].result.rough.outcome.ok();
    if (weak && groups[g].size() > 1) {
      const JointRefineResult first = refine_joint(inputs.back(), config.refine, report);
      if (first.outcome.ok()) {
        for (std::size_t k = 0; k < groups[g].size(); ++k) {
          inputs.back()[k].T_ins_lidar_start = first.lidars[k].T_ins_lidar;
          inputs.back()[k].time_offset_start_s = first.lidars[k].time_offset_s;
        }
      }
    }
    out.push_back(refine_joint_checked(inputs.back(), max_speed_mps, config.refine, report, warnings));
    const JointRefineResult& joint = out.back();
    if (joint.outcome.status == StageStatus::kUndetermined) throw UnobservableError(joint.outcome.message);
    for (std::size_t l : groups[g]) {
      rig.lidars[l].group = g;
      for (const std::string& w : warnings)
        if (w.starts_with(prefix(rig.lidars[l].name))) rig.lidars[l].result.warnings.push_back(w);
    }
    take_joint(joint, groups[g], config, rig);
  }
  return out;
}

void describe_groups(const std::vector<std::vector<std::size_t>>& groups, RigResult& rig) {
  for (const auto& members : groups) {
    for (std::size_t l : members) {
      RigLidar& lidar = rig.lidars[l];
      for (std::size_t o : members)
        if (o != l) lidar.joint_with.push_back(rig.lidars[o].name);
      double best = 0.0;
      for (std::size_t o = 0; o < rig.lidars.size(); ++o)
        if (o != l) best = std::max(best, rig.overlap[l][o]);
      lidar.joint_note = lidar.joint_with.empty()
                             ? fmt::format("overlaps no other LiDAR (largest shared fraction {:.3f}): refined alone", best)
                             : fmt::format("refined jointly with {} in one map", fmt::join(lidar.joint_with, ", "));
    }
  }
}

// One joint segment's frames: LiDAR k's stage-2 frames whose sweep ends in [t0, t1) (INS clock).
std::vector<std::size_t> frames_in(const RefineLidar& in, double t0_s, double t1_s) {
  std::vector<std::size_t> out;
  for (std::size_t i : in.frames) {
    const double t = in.store->data().frames.frames[i].t_end_s + in.time_offset_start_s;
    if (t >= t0_s && t < t1_s) out.push_back(i);
  }
  return out;
}

// The segments' spread per LiDAR, and what it says of the whole drive (as repeatability.cpp:
// range / (d_n sqrt(n)) for n segments), widening the formal stddevs as run_calibration does.
void spread_into(const std::vector<JointRefineResult>& segments, std::size_t k, const std::vector<double>& bounds,
                 std::size_t frames_per_segment, const RepeatabilityConfig& config, CalibrationResult& r) {
  RepeatabilityResult& rep = r.repeatability;
  Vec6 lo = Vec6::Constant(1e300), hi = Vec6::Constant(-1e300);
  for (std::size_t s = 0; s < segments.size(); ++s) {
    const RefineResult& seg = segments[s].lidars[k];
    SegmentResult out{bounds[s], bounds[s + 1], frames_per_segment, segments[s].outcome.ok(), segments[s].outcome.message,
                      seg.T_ins_lidar, seg.time_offset_s};
    rep.segments.push_back(out);
    if (!out.ok) continue;
    ++rep.segments_ok;
    Vec6 v;
    v.head<3>() = seg.T_ins_lidar.translation();
    v.tail<3>() = so3_log(seg.T_ins_lidar.linear() * r.T_ins_lidar.linear().transpose());
    lo = lo.cwiseMin(v);
    hi = hi.cwiseMax(v);
  }
  if (rep.segments_ok < 2) {
    rep.warning = "repeatability: fewer than two segments could be calibrated jointly";
    r.warnings.push_back(rep.warning);
    return;
  }
  rep.spread = hi - lo;
  rep.spread[2] = 0.0;
  constexpr double kRangeFactor[] = {1.0, 1.0, 1.128, 1.693, 2.059, 2.326};
  const double d_n = kRangeFactor[std::min(rep.segments_ok, 5)];
  for (int i : {0, 1, 3, 4, 5}) {
    rep.stddev_whole_drive[i] = rep.spread[i] / (d_n * std::sqrt(double(rep.segments_ok)));
    if (r.determined[i] && !(r.stddev[i] >= rep.stddev_whole_drive[i])) r.stddev[i] = rep.stddev_whole_drive[i];
  }
  if (rep.spread.head<2>().maxCoeff() > config.warn_trans_m || rep.spread.tail<3>().maxCoeff() > config.warn_rot_deg * kRadPerDeg) {
    rep.warning = fmt::format("repeatability: the joint segments disagree by up to {:.1f} cm, {:.3f} deg",
                              100.0 * rep.spread.head<2>().maxCoeff(), rep.spread.tail<3>().maxCoeff() * kDegPerRad);
    r.warnings.push_back(rep.warning);
  }
}

// The repeatability study of a joint group: the drive cut into time segments, the group's stage 2
// on each (every LiDAR's frames inside it) from the same start: stage 1 with the final tz.
void joint_repeatability(const std::vector<RefineLidar>& in, const std::vector<std::size_t>& members,
                         const PipelineConfig& config, RigResult& rig) {
  const auto t0 = std::chrono::steady_clock::now();
  const int n = config.repeatability.segments;
  double lo = 1e300, hi = -1e300;
  for (const RefineLidar& l : in) {
    const std::vector<std::size_t> all = frames_in(l, -1e300, 1e300);
    for (std::size_t i : all) {
      const double t = l.store->data().frames.frames[i].t_end_s + l.time_offset_start_s;
      lo = std::min(lo, t), hi = std::max(hi, t);
    }
  }
  std::vector<double> bounds;
  for (int s = 0; s <= n; ++s) bounds.push_back(lo + (hi - lo) * s / n + (s == n ? 1e-6 : 0.0));
  std::vector<JointRefineResult> segments;
  std::size_t frames = 0;
  for (int s = 0; s < n; ++s) {
    std::vector<RefineLidar> part = in;
    for (std::size_t k = 0; k < part.size(); ++k) {
      const CalibrationResult& r = rig.lidars[members[k]].result;
      part[k].frames = frames_in(in[k], bounds[s], bounds[s + 1]);
      part[k].T_ins_lidar_start = r.rough.T_ins_lidar;
      part[k].T_ins_lidar_start.translation().z() = r.T_ins_lidar.translation().z();
      frames = std::max(frames, part[k].frames.size());
    }
    segments.push_back(refine_joint(part, config.refine));
  }
  for (std::size_t k = 0; k < members.size(); ++k) {
    CalibrationResult& r = rig.lidars[members[k]].result;
    spread_into(segments, k, bounds, frames, config.repeatability, r);
    r.repeatability.wall_time_s = seconds_since(t0);
  }
}

// Stage 3 of every LiDAR and the repeatability study: a LiDAR alone as run_calibration does it,
// a joint group by joint segments.
void finish_all(const std::vector<FrameStore>& stores, const std::vector<std::vector<std::size_t>>& groups,
                const std::vector<std::vector<RefineLidar>>& inputs, const std::vector<FrameGroups>& rough_groups,
                const PipelineConfig& config, const PipelineProgress& progress, RigResult& rig) {
  PipelineConfig no_segments = config;
  no_segments.repeatability.segments = 0;
  for (std::size_t g = 0; g < groups.size(); ++g) {
    const bool joint = groups[g].size() > 1;
    for (std::size_t k = 0; k < groups[g].size(); ++k) {
      const std::size_t l = groups[g][k];
      const std::vector<std::size_t> frames = inputs.empty() ? std::vector<std::size_t>{} : inputs[g][k].frames;
      run_finish(stores[l], rough_groups[l], frames, joint ? no_segments : config,
                 lidar_progress(progress, rig.lidars[l].name), rig.lidars[l].result);
    }
    if (joint && !inputs.empty() && config.repeatability.segments > 1) {
      if (progress) progress("joint repeatability", 0.0);
      joint_repeatability(inputs[g], groups[g], config, rig);
      if (progress) progress("joint repeatability", 1.0);
    }
  }
  for (std::size_t l = 0; l < stores.size(); ++l) rig.lidars[l].result.frames_decoded = stores[l].frames_decoded();
}

// Every pair's transform, its covariance from the final stddevs with the joint correlations.
std::vector<LidarPair> lidar_pairs(const std::vector<std::vector<std::size_t>>& groups,
                                   const std::vector<JointRefineResult>& joints, const RigResult& rig) {
  const std::size_t n = rig.lidars.size();
  std::vector<std::size_t> slot(n, 0);
  for (const auto& members : groups)
    for (std::size_t k = 0; k < members.size(); ++k) slot[members[k]] = k;
  const auto sigma = [&](std::size_t l, int i) {
    const double s = rig.lidars[l].result.stddev[i];
    return std::isfinite(s) ? s : kUnknownSigma;
  };
  const auto corr = [&](std::size_t l, int i, std::size_t m, int j) {
    if (l == m && i == j) return 1.0;
    if (joints.empty() || rig.lidars[l].group != rig.lidars[m].group) return 0.0;
    const Eigen::MatrixXd& cov = joints[rig.lidars[l].group].covariance;
    if (cov.size() == 0) return 0.0;
    const int a = kRefineParams * static_cast<int>(slot[l]) + i, b = kRefineParams * static_cast<int>(slot[m]) + j;
    const double denom = std::sqrt(cov(a, a) * cov(b, b));
    return denom > 0.0 ? cov(a, b) / denom : 0.0;
  };
  std::vector<LidarPair> pairs;
  for (std::size_t a = 0; a < n; ++a) {
    for (std::size_t b = a + 1; b < n; ++b) {
      Mat12 C;
      for (int r = 0; r < 12; ++r)
        for (int c = 0; c < 12; ++c) {
          const std::size_t lr = r < 6 ? a : b, lc = c < 6 ? a : b;
          C(r, c) = corr(lr, r % 6, lc, c % 6) * sigma(lr, r % 6) * sigma(lc, c % 6);
        }
      LidarPair p = lidar_pair(rig.lidars[a].result.T_ins_lidar, rig.lidars[b].result.T_ins_lidar, C);
      p.a = a, p.b = b;
      for (int i = 0; i < 6; ++i)
        if (p.stddev[i] > 0.1 * kUnknownSigma) p.stddev[i] = std::numeric_limits<double>::infinity();
      pairs.push_back(p);
    }
  }
  return pairs;
}

}  // namespace

double map_overlap(const std::vector<Vec3f>& a_world, const std::vector<Vec3f>& b_world, double voxel_m) {
  return keys_overlap(voxel_keys(a_world, voxel_m), voxel_keys(b_world, voxel_m));
}

LidarPair lidar_pair(const Iso3& T_ins_a, const Iso3& T_ins_b, const Mat12& covariance) {
  LidarPair p;
  p.T_a_b = T_ins_a.inverse() * T_ins_b;
  // First order in the INS-frame perturbations: t_a_b = R_a^T (t_b - t_a), R_a_b = R_a^T R_b.
  const Mat3 RaT = T_ins_a.linear().transpose();
  const Vec3 d = T_ins_b.translation() - T_ins_a.translation();
  Eigen::Matrix<double, 6, 12> J = Eigen::Matrix<double, 6, 12>::Zero();
  J.block<3, 3>(0, 0) = -RaT;
  J.block<3, 3>(0, 3) = RaT * skew(d);
  J.block<3, 3>(0, 6) = RaT;
  J.block<3, 3>(3, 3) = -RaT;
  J.block<3, 3>(3, 9) = RaT;
  p.covariance = J * covariance * J.transpose();
  for (int i = 0; i < 6; ++i) p.stddev[i] = std::sqrt(std::max(0.0, p.covariance(i, i)));
  return p;
}

RigResult run_rig_calibration(const std::vector<FrameStore>& stores, const std::vector<std::string>& names,
                              const PipelineConfig& config, const PipelineProgress& progress) {
  const auto start = std::chrono::steady_clock::now();
  if (stores.size() != names.size() || stores.empty())
    throw InputError("rig", "", "one name per LiDAR needed (" + std::to_string(stores.size()) + " LiDARs, " +
                                    std::to_string(names.size()) + " names)");
  RigResult rig;
  rig.lidars.resize(stores.size());
  for (std::size_t l = 0; l < stores.size(); ++l) rig.lidars[l].name = names[l];
  const std::vector<FrameGroups> rough_groups = start_all(stores, config, progress, rig);

  // Which LiDARs share one map: measured on the stage-1 maps.
  if (progress) progress("overlap", 0.0);
  rig.overlap = overlap_matrix(stores, rig, config.refine.joint);
  const std::vector<std::vector<std::size_t>> groups = overlap_groups(rig.overlap, config.refine.joint);
  describe_groups(groups, rig);
  if (progress) progress("overlap", 1.0);

  std::vector<std::vector<RefineLidar>> inputs;
  std::vector<JointRefineResult> joints;
  if (config.run_refine) {
    const auto t_joint = std::chrono::steady_clock::now();
    joints = refine_groups(stores, groups, config, progress, inputs, rig);
    rig.joint_wall_time_s = seconds_since(t_joint);
  }
  if (const std::string why = undetermined_message(rig); !why.empty()) throw UnobservableError(why);
  if (config.trajectory.mode != TrajectoryCorrectionMode::kOff)
    rig.warnings.push_back("rig: the INS trajectory correction is not applied to rigs (trajectory.mode ignored)");

  finish_all(stores, groups, inputs, rough_groups, config, progress, rig);
  rig.pairs = lidar_pairs(groups, joints, rig);
  rig.wall_time_s = seconds_since(start);
  for (RigLidar& lidar : rig.lidars) lidar.result.wall_time_s = rig.wall_time_s;
  return rig;
}

}  // namespace insalign
