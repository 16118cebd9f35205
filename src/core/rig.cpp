#include "core/rig.hpp"

#include <fmt/format.h>
#include <tbb/parallel_invoke.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numeric>

#include "core/errors.hpp"
#include "core/map_registration.hpp"
#include "core/repeatability.hpp"
#include "core/stitch.hpp"
#include "core/voxel_grid.hpp"
#include "core/z_surface.hpp"

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

std::vector<std::size_t> all_lidars(std::size_t n) {
  std::vector<std::size_t> all(n);
  std::iota(all.begin(), all.end(), std::size_t{0});
  return all;
}

// The spans the one INS marks bad itself, found once (every LiDAR's dataset holds that INS's log)
// and left out of every LiDAR's store before any stage.
std::vector<FrameStore> status_screened_stores(const std::vector<FrameStore>& stores, const PipelineConfig& config,
                                               RigResult& rig) {
  const InsScreenResult status = screen_with_status(stores.front().data().ins_quality, config.ins_screen);
  std::vector<FrameStore> out;
  for (std::size_t l = 0; l < stores.size(); ++l) {
    rig.lidars[l].result.ins_screen = status;
    out.push_back(leave_out_spans(stores[l], status.spans));
  }
  return out;
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

// The LiDAR whose stage 1 found the most planes among `members` (a dense LiDAR that sees much,
// and calibrated: a wrong extrinsic blurs planes away, where it would grow an occupied-voxel count).
std::size_t most_planes(const std::vector<std::size_t>& members, const RigResult& rig) {
  std::size_t best = members.front();
  for (std::size_t l : members)
    if (rig.lidars[l].result.rough.planes > rig.lidars[best].result.rough.planes) best = l;
  return best;
}

// Every LiDAR's stage 1 against the map of the one with the most planes: a LiDAR whose sweeps fit
// that map clearly better far from its stage 1 (its own start ended in a wrong basin) gets stage 1
// again from there, kept when that still fits the map clearly better. Where they share too little
// (the registration finds too few of the map's surfaces), nothing changes.
void check_against_reference(const std::vector<FrameStore>& stores, const std::vector<FrameGroups>& rough_groups,
                             const PipelineConfig& config, const PipelineProgress& progress, RigResult& rig) {
  const MapCheckConfig& c = config.refine.joint.map_check;
  if (!c.enabled || !config.refine.joint.enabled || stores.size() < 2) return;
  const std::size_t ref = most_planes(all_lidars(stores.size()), rig);
  const CalibrationResult& rr = rig.lidars[ref].result;
  // One target (kd-tree, normals) for every member: it is most of a check's cost.
  const std::shared_ptr<const PlaneTarget> map = map_target(
      stitch_map(stores[ref], spread_frames(stores[ref], c.map_frames, rr.time_offset_s), rr.T_ins_lidar,
                 rr.time_offset_s, c.map_voxel_m),
      c.registration);
  for (std::size_t l = 0; l < stores.size(); ++l) {
    if (l == ref) continue;
    if (progress) progress(rig.lidars[l].name + ": map check", double(l) / double(stores.size()));
    CalibrationResult& r = rig.lidars[l].result;
    RigMapCheck& check = rig.lidars[l].map_check;
    const MapRegistration registration(stores[l], map, r.time_offset_s, c.registration);
    const MapRegistrationResult reg = registration.solve(r.T_ins_lidar);
    check.reference = rig.lidars[ref].name;
    check.converged = reg.converged;
    check.moved_rot_deg = so3_log(reg.T_ins_lidar.linear() * r.T_ins_lidar.linear().transpose()).norm() * kDegPerRad;
    check.moved_xy_m = (reg.T_ins_lidar.translation() - r.T_ins_lidar.translation()).head<2>().norm();
    // Every fit is taken at the map's tz: tz is stage 3's (stage 1's may be decimetres off) and
    // would otherwise decide a question about rotation and x, y.
    const auto at_map_tz = [&](Iso3 T) {
      T.translation().z() = reg.T_ins_lidar.translation().z();
      return T;
    };
    check.rms_before_m = registration.fit(at_map_tz(r.T_ins_lidar)).rms_m;
    check.rms_after_m = reg.end.rms_m;
    check.T_ins_lidar_map = reg.T_ins_lidar;
    check.T_ins_lidar_map.translation().z() = r.T_ins_lidar.translation().z();  // the map's own tz error moved it
    const bool far = check.moved_rot_deg > c.restart_rot_deg || check.moved_xy_m > c.restart_trans_m;
    if (!reg.converged || !far || check.rms_after_m * c.min_fit_gain > check.rms_before_m) continue;
    const Iso3& start = check.T_ins_lidar_map;
    RoughResult again = calibrate_rough(stores[l], rough_groups[l], start, r.time_offset_s, config.rough);
    check.rms_restarted_m = registration.fit(at_map_tz(again.T_ins_lidar)).rms_m;
    const std::string what = fmt::format(
        "{}its sweeps fit the map of '{}' {:.2f} deg / {:.0f} mm from its stage 1 (point-to-plane RMS {:.1f} mm there, "
        "{:.1f} mm at stage 1)",
        prefix(rig.lidars[l].name), check.reference, check.moved_rot_deg, 1e3 * check.moved_xy_m, 1e3 * check.rms_after_m,
        1e3 * check.rms_before_m);
    // Kept when it still fits the map clearly better. A stage 1 that goes back to where it was is
    // biased there: a LiDAR it could not determine alone starts the joint stage 2 from the map's
    // extrinsic instead; one it did determine contradicts the map, and says so.
    if (check.rms_restarted_m * c.min_fit_gain > check.rms_before_m) {
      if (r.rough.outcome.ok()) {
        r.warnings.push_back(what + fmt::format("; stage 1 from there went back (RMS {:.1f} mm): kept, check this LiDAR",
                                                1e3 * check.rms_restarted_m));
        continue;
      }
      check.map_start = true;
      r.warnings.push_back(what + fmt::format("; its stage 1 (not determined alone) went back from there (RMS {:.1f} mm): "
                                              "the joint stage 2 starts from the map's extrinsic",
                                              1e3 * check.rms_restarted_m));
      r.rough.T_ins_lidar = start;
      r.T_ins_lidar = start;
      continue;
    }
    check.restarted = true;
    r.warnings.push_back(what + fmt::format("; stage 1 restarted from there (RMS {:.1f} mm, {} planes, was {})",
                                            1e3 * check.rms_restarted_m, again.planes, r.rough.planes));
    r.rough = std::move(again);
    r.T_ins_lidar = r.rough.T_ins_lidar;
    r.determined = r.rough.outcome.determined;
    r.stddev = r.rough.outcome.stddev;
    rig.lidars[l].determined_alone = r.rough.outcome.determined;
  }
}

// After every LiDAR's stage 1 and the map check: the LiDAR checks run once, with the LiDAR whose
// stage 1 found the most planes (a sparse side LiDAR's registrations and map offsets are weak and
// noisy), and their spans (INS time) left out of every LiDAR's store. The moving points: one
// evidence for the rig (config.moving.rig_shared), that LiDAR's rays and every LiDAR's points
// placed with its own stage 1; each LiDAR's mask judges its points over its own ground.
void screen_after_stage1_all(std::vector<FrameStore>& stores, std::vector<FrameGroups>& rough_groups,
                             const PipelineConfig& config, const PipelineProgress& progress, RigResult& rig) {
  if (progress) progress("screen", 0.0);
  for (std::size_t l = 0; l < stores.size(); ++l)
    load_check_frames(stores[l], config, rig.lidars[l].result.time_offset_s);
  const std::size_t ref = most_planes(all_lidars(stores.size()), rig);
  const CalibrationResult& rr = rig.lidars[ref].result;
  InsScreenResult checks = lidar_checks(stores[ref], rr.T_ins_lidar, rr.time_offset_s, config.ins_screen);
  for (TimeSpan& span : checks.spans) span.reason += fmt::format(" (found with LiDAR '{}')", rig.lidars[ref].name);
  std::vector<MovingPointsResult> moving;
  if (config.moving.rig_shared) {
    std::vector<FrameStore> screened;
    std::vector<MaskedLidar> lidars;
    for (const FrameStore& store : stores) screened.push_back(leave_out_spans(store, checks.spans));
    for (std::size_t l = 0; l < stores.size(); ++l)
      lidars.push_back({&screened[l], rig.lidars[l].result.T_ins_lidar, rig.lidars[l].result.time_offset_s});
    find_moving_points(lidars, ref, config.moving, moving);
    if (progress) progress("screen", 0.5);
  }
  for (std::size_t l = 0; l < stores.size(); ++l) {
    stores[l] = screen_after_stage1(stores[l], checks, config, rig.lidars[l].result, rough_groups[l],
                                    moving.empty() ? nullptr : &moving[l]);
    if (config.ins_screen.from_lidar) rig.lidars[l].ins_checks_by = rig.lidars[ref].name;
    if (!moving.empty() && moving[l].applied) rig.lidars[l].moving_space_by = rig.lidars[ref].name;
    if (progress) progress("screen", double(l + 1) / double(stores.size()));
  }
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
std::vector<std::vector<double>> overlap_matrix(const std::vector<FrameStore>& stores, RigResult& rig,
                                                const JointConfig& joint) {
  std::vector<std::vector<std::uint64_t>> keys;
  for (std::size_t l = 0; l < stores.size(); ++l) {
    const CalibrationResult& r = rig.lidars[l].result;
    const std::vector<std::size_t> frames = spread_frames(stores[l], joint.overlap_frames, 0.0);
    // Stitched one point per overlap voxel (the same voxels as every point: far fewer keys to sort).
    const double voxel_m = joint.overlap_voxel_m;
    keys.push_back(voxel_keys(stitch_map(stores[l], frames, r.T_ins_lidar, 0.0, voxel_m), voxel_m));
    rig.map_voxels.push_back(keys.back().size());
  }
  std::vector<std::vector<double>> overlap(stores.size(), std::vector<double>(stores.size(), 1.0));
  for (std::size_t a = 0; a < stores.size(); ++a)
    for (std::size_t b = a + 1; b < stores.size(); ++b) overlap[a][b] = overlap[b][a] = keys_overlap(keys[a], keys[b]);
  return overlap;
}

// Connected components of "overlaps at least min_overlap" (every LiDAR alone when disabled); a
// LiDAR the map check moved is tied to its reference: its start came from that map.
std::vector<std::vector<std::size_t>> overlap_groups(const std::vector<std::vector<double>>& overlap,
                                                     const JointConfig& joint, const RigResult& rig) {
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
  for (std::size_t l = 0; l < n && joint.enabled; ++l) {
    const RigMapCheck& check = rig.lidars[l].map_check;
    if (!check.restarted && !check.map_start) continue;
    for (std::size_t r = 0; r < n; ++r)
      if (rig.lidars[r].name == check.reference) root[find(l)] = find(r);
  }
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

// The member whose tz anchors a joint group's heights, whose ground the others' is measured
// against: the one whose stage 1 found the most planes.
std::size_t tz_anchor(const std::vector<std::size_t>& members, const RigResult& rig) { return most_planes(members, rig); }

bool relative_tz(const std::vector<std::size_t>& members, const PipelineConfig& config) {
  return members.size() > 1 && config.refine.joint.relative_tz && !config.refine.estimate_tz;
}

// A joint group's inputs: stage 2 starts from stage 1 with tz fixed by an early stage 3, as
// run_calibration does (a wrong tz biases the horizontal lever arm); with relative_tz only the
// anchor's stays fixed: each LiDAR's fiducial tz is a few mm off, and on the shared ground that
// offset would be absorbed as a tilt of the sparse LiDAR (3 mm over 5 m is 0.03 deg).
std::vector<RefineLidar> group_inputs(const std::vector<FrameStore>& stores, const std::vector<std::size_t>& members,
                                      const PipelineConfig& config, std::vector<NearPoints>& near, RigResult& rig) {
  std::vector<RefineLidar> in;
  const double margin = refine_margin_s(config.refine);
  const bool relative = relative_tz(members, config);
  const std::size_t anchor = tz_anchor(members, rig);
  for (std::size_t l : members) {
    CalibrationResult& r = rig.lidars[l].result;
    const ZResult early_z = correct_z(stores[l], r.T_ins_lidar, r.time_offset_s, config.ins_height_m, config.z, &near[l]);
    if (early_z.determined()) r.T_ins_lidar = early_z.T_ins_lidar;
    in.push_back({rig.lidars[l].name, &stores[l], refine_frames(stores[l], config.refine, r.time_offset_s, margin), r.T_ins_lidar,
                  r.time_offset_s, true, relative && l != anchor,
                  members.size() > 1 && l != anchor ? config.refine.joint.member_max_points : 0});
    if (relative) rig.lidars[l].tz_anchor = rig.lidars[anchor].name;
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
    if (!lidar.tz_anchor.empty())
      lidar.tz_relative_stddev_m = lidar.tz_anchor == lidar.name
                                       ? 0.0
                                       : std::max(r.refine->outcome.stddev[2], config.refine.joint.relative_tz_min_sigma_m);
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
                                             std::vector<NearPoints>& near, std::vector<std::vector<RefineLidar>>& inputs,
                                             RigResult& rig) {
  std::vector<JointRefineResult> out;
  for (std::size_t g = 0; g < groups.size(); ++g) {
    inputs.push_back(group_inputs(stores, groups[g], config, near, rig));
    double max_speed_mps = 0.0;
    for (std::size_t l : groups[g]) max_speed_mps = std::max(max_speed_mps, rig.lidars[l].result.motion.max_speed_mps);
    std::vector<std::string> warnings;
    const std::string step = groups[g].size() > 1 ? "joint refine" : rig.lidars[groups[g].front()].name + ": refine";
    const auto report = [&](double f) { if (progress) progress(step, f); };
    // The lever-arm check assumes stage 1 within a few centimetres; a LiDAR that stage 1 could
    // not determine alone starts further out: unchecked joint passes first (each re-finds the
    // planes on a sharper map; from 0.1 deg and 3 cm off a weak LiDAR needed three), then the
    // checked one from there.
    bool weak = false;
    for (std::size_t l : groups[g]) weak = weak || !rig.lidars[l].result.rough.outcome.ok();
    for (int pass = 0; weak && groups[g].size() > 1 && pass < config.refine.joint.weak_passes; ++pass) {
      const JointRefineResult first = refine_joint(inputs.back(), config.refine, report);
      if (!first.outcome.ok()) break;
      double moved_deg = 0.0, moved_m = 0.0;
      for (std::size_t k = 0; k < groups[g].size(); ++k) {
        RefineLidar& in = inputs.back()[k];
        const Iso3& T = first.lidars[k].T_ins_lidar;
        moved_deg = std::max(moved_deg, so3_log(T.linear() * in.T_ins_lidar_start.linear().transpose()).norm() * kDegPerRad);
        moved_m = std::max(moved_m, (T.translation() - in.T_ins_lidar_start.translation()).norm());
        in.T_ins_lidar_start = T;
        in.time_offset_start_s = first.lidars[k].time_offset_s;
      }
      if (moved_deg < 1e-3 && moved_m < 1e-4) break;
    }
    out.push_back(refine_joint_checked(inputs.back(), max_speed_mps, config.refine, report, warnings));
    const JointRefineResult& joint = out.back();
    if (joint.outcome.status == StageStatus::kUndetermined) throw UnobservableError(joint.outcome.message);
    for (std::size_t l : groups[g]) {
      rig.lidars[l].group = g;
      std::vector<std::string>& own = rig.lidars[l].result.warnings;
      for (const std::string& w : warnings)  // once: stage 2 runs again on a corrected trajectory
        if (w.starts_with(prefix(rig.lidars[l].name)) && std::find(own.begin(), own.end(), w) == own.end()) own.push_back(w);
    }
    take_joint(joint, groups[g], config, rig);
  }
  return out;
}

// The INS trajectory correction, estimated with the LiDAR whose checks ran (the most planes)
// exactly as for one LiDAR. Applied, its trajectory is the rig's: every group's stage 2 runs again
// on the corrected poses, and every stddev takes the correction's own in (the trajectory's errors
// are common to the rig); stage 3 and the repeatability study keep the reported poses, as for one
// LiDAR. Not applied, every LiDAR carries the drift it measured, as the reference does.
void correct_rig_trajectory(const std::vector<FrameStore>& stores, const std::vector<std::vector<std::size_t>>& groups,
                            const PipelineConfig& config, const PipelineProgress& progress, std::vector<NearPoints>& near,
                            std::vector<std::vector<RefineLidar>>& inputs, std::vector<JointRefineResult>& joints,
                            RigResult& rig) {
  const std::size_t ref = most_planes(all_lidars(stores.size()), rig);
  const std::string& name = rig.lidars[ref].name;
  const std::vector<std::size_t>& members = groups[rig.lidars[ref].group];
  const std::size_t slot = static_cast<std::size_t>(std::find(members.begin(), members.end(), ref) - members.begin());
  CalibrationResult& rr = rig.lidars[ref].result;
  run_trajectory_correction(stores[ref], inputs[rig.lidars[ref].group][slot].frames, config,
                            lidar_progress(progress, name), rr);
  const TrajectoryCorrection tc = rr.trajectory;
  if (tc.t_s.size() < 2) return;  // not estimated: off, an INS that does not drift, too few frames
  const auto share = [&](CalibrationResult& r) {
    r.trajectory = tc;
    r.trajectory.T_ins_lidar = r.T_ins_lidar;
    r.trajectory.time_offset_s = r.time_offset_s;  // its knots' times read on this LiDAR's clock
    r.trajectory.decision += fmt::format(" (estimated with LiDAR '{}')", name);
  };
  if (!tc.applied) {
    const double span_s = tc.t_s.back() - tc.t_s.front();
    for (std::size_t l = 0; l < stores.size(); ++l) {
      CalibrationResult& r = rig.lidars[l].result;
      if (l != ref && r.refine) {
        const auto drift = random_walk_stddev(*r.refine, tc.correction_rms_axes_m, span_s);
        for (int i : {0, 1, 3, 4, 5}) r.ins_drift_stddev[i] = drift[i];
        if (r.refine->time_offset_estimated) r.ins_drift_stddev[6] = drift[6];
      }
      share(r);
    }
    rig.warnings.push_back("rig: " + rig.lidars[ref].result.trajectory.decision);
    return;
  }
  std::vector<FrameStore> corrected;
  for (const FrameStore& store : stores) corrected.push_back(store.with(corrected_poses(store.poses(), tc), store.excluded()));
  std::vector<std::vector<RefineLidar>> again;
  joints = refine_groups(corrected, groups, config, progress, near, again, rig);
  for (std::size_t g = 0; g < groups.size(); ++g)
    for (std::size_t k = 0; k < groups[g].size(); ++k) again[g][k].store = &stores[groups[g][k]];
  inputs = std::move(again);
  for (std::size_t l = 0; l < stores.size(); ++l) {
    CalibrationResult& r = rig.lidars[l].result;
    for (int i : {0, 1, 3, 4, 5})
      if (std::isfinite(r.stddev[i]) && std::isfinite(tc.outcome.stddev[i])) r.stddev[i] = std::hypot(r.stddev[i], tc.outcome.stddev[i]);
    r.ins_drift_stddev.setZero();  // stage 2 estimated everything again on the corrected poses
    share(r);
  }
  rig.warnings.push_back(fmt::format("rig: {}: every LiDAR's stage 2 ran again on the corrected trajectory",
                                     rig.lidars[ref].result.trajectory.decision));
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
                 std::size_t frames_per_segment, const RepeatabilityConfig& config, RigLidar& lidar) {
  CalibrationResult& r = lidar.result;
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
  // tz moves in the segments only relative to the anchor (stage 2's relative heights): its spread
  // widens that relative part; the anchor's own tz stays stage 3's.
  const bool tz_relative = std::isfinite(lidar.tz_relative_stddev_m) && lidar.tz_relative_stddev_m > 0.0;
  if (!tz_relative) rep.spread[2] = 0.0;
  const double per_spread = whole_drive_stddev_per_spread(rep.segments_ok);
  for (int i : {0, 1, 3, 4, 5}) rep.stddev_whole_drive[i] = rep.spread[i] * per_spread;
  // The one LiDAR's rule (core/repeatability): at least the segments' spread, and the formal
  // stddev inflated by the DOFs' pooled segments/formal ratio (three segments agree by chance).
  const Vec6 widened = stddev_with_repeatability(r.stddev, rep);
  for (int i : {0, 1, 3, 4, 5})
    if (r.determined[i]) r.stddev[i] = widened[i];
  if (tz_relative) {
    rep.stddev_whole_drive[2] = rep.spread[2] * per_spread;
    lidar.tz_relative_stddev_m = std::max(lidar.tz_relative_stddev_m, rep.stddev_whole_drive[2]);
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
  // Each LiDAR's offset starts at the joint run's, without the coarse scan that would land there
  // again (as a single LiDAR's segments, core/repeatability).
  RefineConfig segment_refine = config.refine;
  segment_refine.time_offset_scan_step_s = 0.0;
  segment_refine.extrinsic_only = true;
  for (int s = 0; s < n; ++s) {
    std::vector<RefineLidar> part = in;
    for (std::size_t k = 0; k < part.size(); ++k) {
      const CalibrationResult& r = rig.lidars[members[k]].result;
      part[k].frames = frames_in(in[k], bounds[s], bounds[s + 1]);
      part[k].T_ins_lidar_start = r.rough.T_ins_lidar;
      part[k].T_ins_lidar_start.translation().z() = r.T_ins_lidar.translation().z();
      part[k].time_offset_start_s = r.time_offset_s;
      frames = std::max(frames, part[k].frames.size());
    }
    segments.push_back(refine_joint(part, segment_refine));
  }
  for (std::size_t k = 0; k < members.size(); ++k) {
    CalibrationResult& r = rig.lidars[members[k]].result;
    spread_into(segments, k, bounds, frames, config.repeatability, rig.lidars[members[k]]);
    r.repeatability.wall_time_s = seconds_since(t0);
  }
}

// Relative tz, shared stage 3: stage 2 fixed the members' heights relative to the anchor on the
// shared ground, to about a millimetre; each one's own fiducial tz is worse (a sparse LiDAR meets
// the ground at the fiducials in a few rings only) and would break that relation again, so one
// stage-3 change moves every member alike: the median of the members' own changes (each measures
// the same common height; the median stays right when one LiDAR is badly off, as a LiDAR whose
// stage 1 ended in a wrong basin is). A member whose own change disagrees beyond 3 sigma gets a
// warning: its own stage 3 is kept as a check.
std::size_t anchor_of(const std::vector<std::size_t>& members, const RigResult& rig) {
  std::size_t anchor = members.front();
  for (std::size_t l : members)
    if (rig.lidars[l].tz_anchor == rig.lidars[l].name) anchor = l;
  return anchor;
}

// Each LiDAR's final status; a LiDAR whose tz is the anchor's relative height has the anchor's source.
void finish_rig_dof_status(const PipelineConfig& config, RigResult& rig) {
  std::vector<TzSource> own(rig.lidars.size());
  for (std::size_t l = 0; l < rig.lidars.size(); ++l) own[l] = final_tz_source(rig.lidars[l].result);
  for (std::size_t l = 0; l < rig.lidars.size(); ++l) {
    RigLidar& lidar = rig.lidars[l];
    std::optional<TzSource> source;
    for (std::size_t a = 0; a < rig.lidars.size(); ++a)
      if (lidar.tz_from_anchor && rig.lidars[a].name == lidar.tz_anchor) source = own[a];
    finish_dof_status(config, lidar.result, source);
  }
}

// Their tz stddev: the anchor's (absolute) and their own relative part (after the repeatability
// study widened it).
void shared_tz_stddevs(const std::vector<std::size_t>& members, RigResult& rig) {
  const double sd_anchor_m = rig.lidars[anchor_of(members, rig)].result.stddev[2];
  for (std::size_t l : members)
    if (rig.lidars[l].tz_from_anchor) rig.lidars[l].result.stddev[2] = std::hypot(sd_anchor_m, rig.lidars[l].tz_relative_stddev_m);
}

void share_anchor_stage3(const std::vector<std::size_t>& members, const std::vector<double>& tz_before_m,
                         RigResult& rig) {
  const std::size_t anchor = anchor_of(members, rig);
  std::vector<double> own_dz_m;
  for (std::size_t l : members)
    if (rig.lidars[l].result.z.determined()) own_dz_m.push_back(rig.lidars[l].result.z.dz_m);
  if (own_dz_m.empty()) return;  // nothing to share: each keeps what its own stage 3 said
  std::sort(own_dz_m.begin(), own_dz_m.end());
  const std::size_t m = own_dz_m.size();
  const double dz_m = m % 2 ? own_dz_m[m / 2] : 0.5 * (own_dz_m[m / 2 - 1] + own_dz_m[m / 2]);
  const CalibrationResult& a = rig.lidars[anchor].result;
  const double sd_common_m = a.z.determined() ? a.stddev[2] : a.z.tz_stddev_m();
  for (std::size_t k = 0; k < members.size(); ++k) {
    RigLidar& lidar = rig.lidars[members[k]];
    CalibrationResult& r = lidar.result;
    const bool is_anchor = members[k] == anchor;
    if (!is_anchor && !std::isfinite(lidar.tz_relative_stddev_m)) continue;
    const double own_dz = r.z.determined() ? r.z.dz_m : std::nan("");
    if (r.z.determined()) lidar.own_stage3_tz_m = r.T_ins_lidar.translation().z();
    lidar.tz_from_anchor = !is_anchor;
    r.T_ins_lidar.translation().z() = tz_before_m[k] + dz_m;
    r.stddev[2] = is_anchor ? sd_common_m : std::hypot(sd_common_m, lidar.tz_relative_stddev_m);
    r.determined[2] = true;
    const double own_sd_m = r.z.determined() ? r.z.tz_stddev_m() : 0.0;
    if (std::isfinite(own_dz) && std::abs(own_dz - dz_m) > 3.0 * std::hypot(own_sd_m, r.stddev[2]))
      r.warnings.push_back(fmt::format("{}its own stage 3 moves tz by {:+.1f} mm, the rig's (median of {} LiDARs) by "
                                       "{:+.1f} mm: the relative height from the joint map was kept; check this LiDAR",
                                       prefix(lidar.name), 1e3 * own_dz, m, 1e3 * dz_m));
    r.z.T_ins_lidar = r.T_ins_lidar;
    r.z.dz_m = dz_m;
    r.z.outcome.message += fmt::format(" (rig: tz = the joint height relative to '{}' plus the median of {} LiDARs' "
                                       "stage-3 changes; own stage 3 said {:+.1f} mm)",
                                       rig.lidars[anchor].name, m, 1e3 * own_dz);
  }
}

// Stage 3 of every LiDAR and the repeatability study: a LiDAR alone as run_calibration does it,
// a joint group by joint segments.
void finish_all(const std::vector<FrameStore>& stores, const std::vector<std::vector<std::size_t>>& groups,
                const std::vector<std::vector<RefineLidar>>& inputs, const std::vector<FrameGroups>& rough_groups,
                const PipelineConfig& config, std::vector<NearPoints>& near, const PipelineProgress& progress,
                const RigBeside& beside, RigResult& rig) {
  PipelineConfig no_segments = config;
  no_segments.repeatability.segments = 0;
  for (std::size_t g = 0; g < groups.size(); ++g) {
    const bool joint = groups[g].size() > 1;
    std::vector<double> tz_before_m;
    for (std::size_t k = 0; k < groups[g].size(); ++k) {
      const std::size_t l = groups[g][k];
      tz_before_m.push_back(rig.lidars[l].result.T_ins_lidar.translation().z());
      const std::vector<std::size_t> frames = inputs.empty() ? std::vector<std::size_t>{} : inputs[g][k].frames;
      const BesideRepeatability alone = [&](const CalibrationResult& r) {
        if (beside) beside(l, r);
      };
      run_finish(stores[l], rough_groups[l], frames, joint ? no_segments : config,
                 lidar_progress(progress, rig.lidars[l].name), rig.lidars[l].result, joint ? nullptr : alone, &near[l]);
    }
    if (joint && config.refine.joint.shared_stage3 && !rig.lidars[groups[g].front()].tz_anchor.empty())
      share_anchor_stage3(groups[g], tz_before_m, rig);
    // The members' extrinsics are final now; the study changes only their stddevs and warnings.
    const auto study = [&] {
      if (!joint || inputs.empty() || config.repeatability.segments <= 1) return;
      if (progress) progress("joint repeatability", 0.0);
      joint_repeatability(inputs[g], groups[g], config, rig);
      if (progress) progress("joint repeatability", 1.0);
    };
    tbb::parallel_invoke(study, [&] {
      if (!joint || !beside) return;
      for (std::size_t l : groups[g]) beside(l, rig.lidars[l].result);
    });
    if (joint) shared_tz_stddevs(groups[g], rig);
  }
  for (std::size_t l = 0; l < stores.size(); ++l) rig.lidars[l].result.frames_decoded = stores[l].frames_decoded();
}

// Each LiDAR's 6 stddevs as the joint covariance's correlations scale them: the final ones, but
// for a tz that follows its anchor only its part relative to the anchor (the anchor's own
// stage-3 error is common to the group: common_tz_var).
struct PairInputs {
  std::vector<std::size_t> slot;         // a LiDAR's place in its group's joint covariance
  std::vector<Vec6> sigma;               // per LiDAR
  std::vector<double> common_tz_var;     // per group: the anchor's tz variance shared by its followers
};

PairInputs pair_inputs(const std::vector<std::vector<std::size_t>>& groups, const RigResult& rig) {
  PairInputs in;
  const std::size_t n = rig.lidars.size();
  in.slot.assign(n, 0);
  in.sigma.assign(n, Vec6::Constant(kUnknownSigma));
  in.common_tz_var.assign(groups.size(), 0.0);
  for (std::size_t g = 0; g < groups.size(); ++g) {
    for (std::size_t k = 0; k < groups[g].size(); ++k) in.slot[groups[g][k]] = k;
    bool shared = false;
    for (std::size_t l : groups[g]) shared = shared || rig.lidars[l].tz_from_anchor;
    const double sd_anchor = rig.lidars[anchor_of(groups[g], rig)].result.stddev[2];
    if (shared && std::isfinite(sd_anchor)) in.common_tz_var[g] = sd_anchor * sd_anchor;
    for (std::size_t l : groups[g]) {
      const RigLidar& lidar = rig.lidars[l];
      for (int i = 0; i < 6; ++i)
        if (std::isfinite(lidar.result.stddev[i])) in.sigma[l][i] = lidar.result.stddev[i];
      if (shared && std::isfinite(sd_anchor) && (lidar.tz_from_anchor || l == anchor_of(groups[g], rig)))
        in.sigma[l][2] = lidar.tz_from_anchor ? lidar.tz_relative_stddev_m : 0.0;
    }
  }
  return in;
}

// The 12x12 covariance of [a, b]'s INS-frame perturbations: the joint correlations (zero across
// groups) times the sigmas, plus the common tz part where both follow one anchor.
Mat12 pair_covariance(std::size_t a, std::size_t b, const PairInputs& in, const std::vector<JointRefineResult>& joints,
                      const RigResult& rig) {
  const auto corr = [&](std::size_t l, int i, std::size_t m, int j) {
    if (l == m && i == j) return 1.0;
    if (joints.empty() || rig.lidars[l].group != rig.lidars[m].group) return 0.0;
    const Eigen::MatrixXd& cov = joints[rig.lidars[l].group].covariance;
    if (cov.size() == 0) return 0.0;
    const int r = kRefineParams * static_cast<int>(in.slot[l]) + i, c = kRefineParams * static_cast<int>(in.slot[m]) + j;
    const double denom = std::sqrt(cov(r, r) * cov(c, c));
    return denom > 0.0 ? cov(r, c) / denom : 0.0;
  };
  Mat12 C;
  for (int r = 0; r < 12; ++r)
    for (int c = 0; c < 12; ++c) {
      const std::size_t lr = r < 6 ? a : b, lc = c < 6 ? a : b;
      C(r, c) = corr(lr, r % 6, lc, c % 6) * in.sigma[lr][r % 6] * in.sigma[lc][c % 6];
    }
  if (rig.lidars[a].group == rig.lidars[b].group) {
    const double common = in.common_tz_var.empty() ? 0.0 : in.common_tz_var[rig.lidars[a].group];
    for (int r : {2, 8})
      for (int c : {2, 8}) C(r, c) += common;
  } else {
    for (std::size_t l : {a, b}) C((l == a ? 2 : 8), (l == a ? 2 : 8)) += in.common_tz_var[rig.lidars[l].group];
  }
  return C;
}

// A joint group's pair per repeatability segment: its spread scaled to the whole drive (as
// spread_into does per LiDAR) is a floor for the pair's stddev. The LiDARs' widened stddevs with
// the formal correlations can still be too small for the pair: the segments' errors of two
// LiDARs need not be correlated as the formal covariance says (measured: up to 4x too small).
Vec6 pair_spread_stddev(const RigLidar& a, const RigLidar& b, const Iso3& T_a_b) {
  const auto& sa = a.result.repeatability.segments;
  const auto& sb = b.result.repeatability.segments;
  Vec6 lo = Vec6::Constant(1e300), hi = Vec6::Constant(-1e300);
  std::size_t ok = 0;
  for (std::size_t s = 0; s < std::min(sa.size(), sb.size()); ++s) {
    if (!sa[s].ok || !sb[s].ok) continue;
    const Iso3 T = sa[s].T_ins_lidar.inverse() * sb[s].T_ins_lidar;
    Vec6 v;
    v.head<3>() = T.translation();
    v.tail<3>() = so3_log(T.linear() * T_a_b.linear().transpose());
    lo = lo.cwiseMin(v), hi = hi.cwiseMax(v), ++ok;
  }
  if (ok < 2) return Vec6::Zero();
  return (hi - lo) * whole_drive_stddev_per_spread(static_cast<int>(ok));
}

// Every pair's transform and its covariance (pair_covariance), each DOF widened to at least the
// pair's own repeatability spread (correlations kept).
std::vector<LidarPair> lidar_pairs(const std::vector<std::vector<std::size_t>>& groups,
                                   const std::vector<JointRefineResult>& joints, const RigResult& rig) {
  const std::size_t n = rig.lidars.size();
  const PairInputs in = pair_inputs(groups, rig);
  std::vector<LidarPair> pairs;
  for (std::size_t a = 0; a < n; ++a) {
    for (std::size_t b = a + 1; b < n; ++b) {
      const RigLidar &la = rig.lidars[a], &lb = rig.lidars[b];
      LidarPair p = lidar_pair(la.result.T_ins_lidar, lb.result.T_ins_lidar, pair_covariance(a, b, in, joints, rig));
      p.a = a, p.b = b;
      if (la.group == lb.group) {
        const Vec6 floor = pair_spread_stddev(la, lb, p.T_a_b);
        for (int i = 0; i < 6; ++i) {
          if (!(floor[i] > p.stddev[i]) || p.stddev[i] <= 0.0) continue;
          const double f = floor[i] / p.stddev[i];
          p.covariance.row(i) *= f;
          p.covariance.col(i) *= f;
          p.stddev[i] = floor[i];
        }
      }
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
                              const PipelineConfig& config, const PipelineProgress& progress, const RigBeside& beside) {
  const auto start = std::chrono::steady_clock::now();
  if (stores.size() != names.size() || stores.empty())
    throw InputError("rig", "", "one name per LiDAR needed (" + std::to_string(stores.size()) + " LiDARs, " +
                                    std::to_string(names.size()) + " names)");
  RigResult rig;
  rig.lidars.resize(stores.size());
  for (std::size_t l = 0; l < stores.size(); ++l) rig.lidars[l].name = names[l];
  // Every step reads the screened stores (sharing the inputs' decoded frames), as run_calibration does.
  std::vector<FrameStore> screened = status_screened_stores(stores, config, rig);
  std::vector<FrameGroups> rough_groups = start_all(screened, config, progress, rig);
  check_against_reference(screened, rough_groups, config, progress, rig);
  screen_after_stage1_all(screened, rough_groups, config, progress, rig);

  // Which LiDARs share one map: measured on the stage-1 maps.
  if (progress) progress("overlap", 0.0);
  rig.overlap = overlap_matrix(screened, rig, config.refine.joint);
  const std::vector<std::vector<std::size_t>> groups = overlap_groups(rig.overlap, config.refine.joint, rig);
  describe_groups(groups, rig);
  if (progress) progress("overlap", 1.0);

  std::vector<std::vector<RefineLidar>> inputs;
  std::vector<JointRefineResult> joints;
  std::vector<NearPoints> near(stores.size());  // each LiDAR's stage 3 runs before and after stage 2
  if (config.run_refine) {
    const auto t_joint = std::chrono::steady_clock::now();
    joints = refine_groups(screened, groups, config, progress, near, inputs, rig);
    correct_rig_trajectory(screened, groups, config, progress, near, inputs, joints, rig);
    rig.joint_wall_time_s = seconds_since(t_joint);
  }
  if (const std::string why = undetermined_message(rig); !why.empty()) throw UnobservableError(why);
  finish_all(screened, groups, inputs, rough_groups, config, near, progress, beside, rig);
  rig.pairs = lidar_pairs(groups, joints, rig);  // before: the INS's errors are common to all
  for (RigLidar& lidar : rig.lidars) add_ins_position_error(lidar.result), add_ins_heading_error(config, lidar.result);
  finish_rig_dof_status(config, rig);
  rig.wall_time_s = seconds_since(start);
  for (RigLidar& lidar : rig.lidars) lidar.result.wall_time_s = rig.wall_time_s;
  return rig;
}

}  // namespace insalign
