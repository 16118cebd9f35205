#include "core/global_init.hpp"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>
#include <sstream>

#include <fmt/format.h>

#include "core/deskew.hpp"
#include "core/occupancy.hpp"

namespace insalign {
namespace {

using Clock = std::chrono::steady_clock;


std::vector<Vec3> to_vec3(const std::vector<Vec3f>& points) {
  std::vector<Vec3> out(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) out[i] = points[i].cast<double>();
  return out;
}

// Which frames each step uses, as positions into the drive's covered frames.
struct InitPlan {
  std::vector<std::size_t> level, coarse;
  std::vector<std::pair<std::size_t, std::size_t>> pairs;
  double coarse_stretch_m = 0.0;
};

InitPlan plan_frames(const DriveFrames& drive, double period_s, const GlobalInitConfig& config) {
  InitPlan plan;
  const auto [a, b] = straightest_stretch(drive, config.coarse.stretch_m);
  plan.coarse = spread_over_motion(drive, static_cast<std::size_t>(config.coarse.frames), a, b);
  plan.coarse_stretch_m = drive.motion_m[b] - drive.motion_m[a];
  plan.pairs = hand_eye_pairs(drive, period_s, config.hand_eye);
  plan.level = spread_over_motion(drive, static_cast<std::size_t>(config.ground.level_frames));
  return plan;
}

// Every frame the plan needs, loaded once (in parallel), with its ground plane; by position.
std::map<std::size_t, InitFrame> load_frames(const FrameStore& store, const DriveFrames& drive, const InitPlan& plan,
                                             const GlobalInitConfig& config) {
  std::vector<std::size_t> need(plan.level.begin(), plan.level.end());
  need.insert(need.end(), plan.coarse.begin(), plan.coarse.end());
  for (const auto& [a, b] : plan.pairs) need.insert(need.end(), {a, b});
  std::sort(need.begin(), need.end());
  need.erase(std::unique(need.begin(), need.end()), need.end());
  std::vector<InitFrame> frames(need.size());
  tbb::parallel_for(std::size_t{0}, need.size(), [&](std::size_t k) {
    InitFrame& f = frames[k];
    f.index = drive.index[need[k]];
    f.T_world_ins = drive.T_world_ins[need[k]];
    f.sweep = thin_sweep(store.reduced(f.index), config.filter);
    f.ground_candidates = ground_candidates(to_vec3(f.sweep.p_lidar), config.ground, static_cast<unsigned>(f.index + 1));
  });
  std::map<std::size_t, InitFrame> out;
  for (std::size_t k = 0; k < need.size(); ++k) out.emplace(need[k], std::move(frames[k]));
  return out;
}

// Height of the INS origin above the ground: from the nearest fiducials (ground points) where
// the drive passes within 30 m of one, else the configured guess. `how` says which.
double ins_height_above_ground(const std::vector<InitFrame*>& frames, const std::vector<Fiducial>& fiducials,
                               double guess_m, std::optional<double> given_m, std::string& how, TzSource& source) {
  double sum = 0.0;
  int count = 0;
  for (const InitFrame* f : frames) {
    const Vec3 p_ins = f->T_world_ins.translation();
    const Fiducial* nearest = nullptr;
    for (const Fiducial& fid : fiducials)
      if (!nearest || (fid.p_world - p_ins).head<2>().norm() < (nearest->p_world - p_ins).head<2>().norm()) nearest = &fid;
    if (nearest && (nearest->p_world - p_ins).head<2>().norm() < 30.0) sum += p_ins.z() - nearest->p_world.z(), ++count;
  }
  if (count == 0 && given_m) {
    how = fmt::format("INS {:.2f} m above the ground (--ins-height-m; stage 3 measures z)", *given_m);
    source = TzSource::kInsHeightGiven;
    return *given_m;
  }
  if (count == 0) {
    how = fmt::format("INS assumed {:.2f} m above the ground (the built-in guess: no fiducials, no --ins-height-m)", guess_m);
    source = TzSource::kGuess;
    return guess_m;
  }
  how = fmt::format("INS {:.2f} m above the ground (nearest fiducials)", sum / count);
  source = TzSource::kFiducials;
  return sum / count;
}

// Sum over groups of the occupied voxels of each group's stitched off-ground points.
double score_candidate(const std::vector<std::vector<const InitFrame*>>& groups, const PoseStream& poses,
                       const Iso3& T_ins_lidar, double time_offset_s, double voxel_m) {
  double total = 0.0;
  for (const auto& group : groups) {
    std::vector<Vec3> p_world;
    for (const InitFrame* f : group) {
      if (!sweep_covered(poses, f->sweep, time_offset_s)) continue;
      const std::vector<Vec3f> placed =
          sweep_to_world(f->sweep, poses, T_ins_lidar, PlaceOptions{.time_offset_s = time_offset_s});
      for (std::size_t i = 0; i < placed.size(); ++i)
        if (f->off_ground[i]) p_world.push_back(placed[i].cast<double>());
    }
    total += occupancy_score(p_world, voxel_m);
  }
  return total;
}

// The time offset the pairs' rotation angles show (the LiDAR's angle between two sweeps is the
// INS's between the same instants, whatever the extrinsic).
CoarseTimeOffset time_offset_of(const std::vector<MotionPair>& motions, const PoseStream& poses,
                                const CoarseTimeOffsetConfig& config, double reference_s) {
  std::vector<AnglePair> angles;
  for (const MotionPair& m : motions)
    angles.push_back({m.t0_s, m.t1_s, Eigen::AngleAxisd(m.T_lev0_lev1.linear()).angle() * kDegPerRad});
  return fit_time_offset(angles, poses, config, reference_s);
}

// The data's candidates (its estimate turned about the vertical, the coarse one) and the init.
std::vector<InitCandidate> make_candidates(const Iso3& T_data, const std::optional<Iso3>& T_coarse,
                                           const std::optional<Iso3>& T_init, const Levelling& level) {
  auto turned = [&](double deg) {  // the INS axes turned about the levelled vertical
    Iso3 R = Iso3::Identity();
    R.linear() = level.R_ins_insl * Eigen::AngleAxisd(deg * kRadPerDeg, Vec3::UnitZ()).toRotationMatrix() *
                 level.R_ins_insl.transpose();
    return R * T_data;
  };
  std::vector<InitCandidate> out = {
      {T_data, 0, "data"}, {turned(90), 0, "data-yaw+90"}, {turned(180), 0, "data-yaw+180"}, {turned(-90), 0, "data-yaw-90"}};
  if (T_coarse) out.push_back({*T_coarse, 0, "data-coarse"});
  if (T_init) out.push_back({*T_init, 0, "init"});
  return out;
}

// With an init: keep it in the data's basin or when the data is not clearly better elsewhere.
void decide(const std::vector<InitCandidate>& cand, const std::optional<Iso3>& T_init, const GlobalInitConfig& config,
            GlobalInitResult& result, std::ostringstream& why) {
  std::size_t best = 0;  // the best of the data's candidates (normally "data" itself)
  for (std::size_t k = 0; k < cand.size(); ++k)
    if (cand[k].label != "init" && cand[k].score < cand[best].score) best = k;
  if (!T_init) {
    result.T_ins_lidar = cand[best].T_ins_lidar;
    result.start_candidate = cand[best].label;
    result.source = InitSource::kData;
    why << " No init given: chose " << cand[best].label << ".";
    return;
  }
  const InitCandidate& init = cand.back();
  const ExtrinsicError diff = extrinsic_error(init.T_ins_lidar, cand[best].T_ins_lidar);
  const bool same_basin = diff.angle_deg < config.same_basin_rot_deg && diff.dt_norm_m < config.same_basin_trans_m;
  const double ratio = init.score / cand[best].score;
  why << " Init differs from " << cand[best].label << fmt::format(" by {:.1f} deg and {:.2f} m", diff.angle_deg, diff.dt_norm_m);
  result.T_ins_lidar = *T_init;
  result.source = InitSource::kInit;
  result.init_near_data = cand[best].label == "data" && diff.angle_deg < config.near_data_rot_deg &&
                          (init.T_ins_lidar.translation() - cand[best].T_ins_lidar.translation()).head<2>().norm() <
                              config.near_data_trans_m;
  if (same_basin && ratio > config.override_score_ratio) {
    result.T_ins_lidar = cand[best].T_ins_lidar;
    result.T_ins_lidar.translation().z() = T_init->translation().z();  // the data's z is a guess without fiducials
    result.start_candidate = cand[best].label;
    result.source = InitSource::kDataNearInit;
    why << fmt::format(": same basin, init confirmed; starting from {} (with the init's z), which scores {:.3f} times "
                       "crisper.", cand[best].label, ratio);
  } else if (same_basin) {
    why << ": same basin, init confirmed.";
  } else if (ratio > config.override_score_ratio) {
    result.T_ins_lidar = cand[best].T_ins_lidar;
    // The data's rotation and lever arm, the init's tz: the drive does not show tz here, and the
    // user's measured height beats the guess (seen: 0.79 m off from a guess, the init 0.21 m).
    result.T_ins_lidar.translation().z() = T_init->translation().z();
    result.start_candidate = cand[best].label;
    result.source = InitSource::kDataOverridesInit;
    why << ": the data clearly prefers " << cand[best].label
        << fmt::format(" (init scores {:.3f} times worse, threshold {:.3f}); continuing from the data (with the init's z).", ratio,
               config.override_score_ratio);
  } else {
    why << fmt::format(": the data does not clearly prefer another basin (score ratio init/data {:.3f} <= {:.3f}); init kept.",
               ratio, config.override_score_ratio);
  }
}

// The data cannot give a start: the init if there is one (unchecked), else undetermined.
GlobalInitResult cannot_start(const std::optional<Iso3>& T_init, double time_offset_s, const std::string& why,
                              Clock::time_point t0) {
  GlobalInitResult result;
  result.time_offset_s = result.time_offset.offset_s = time_offset_s;
  if (T_init) {
    result.T_ins_lidar = *T_init;
    result.source = InitSource::kInit;
    result.explanation = "init kept unchecked: global initialisation: " + why;
    result.candidates.push_back({*T_init, 0.0, "init"});
    result.outcome.status = StageStatus::kOk;
  } else {
    result.outcome.status = StageStatus::kUndetermined;
    result.outcome.message = "global initialisation: " + why;
    result.explanation = result.outcome.message;
  }
  result.outcome.wall_time_s = std::chrono::duration<double>(Clock::now() - t0).count();
  return result;
}

}  // namespace

bool start_is_near(const GlobalInitResult& init) {
  const bool data_near = init.hand_eye_pairs_used > 0 && init.lever_arm_observed;
  const bool init_kept = init.source == InitSource::kInit && init.start_candidate == "init";
  return data_near && (init.start_candidate == "data" || (init_kept && init.init_near_data));
}

GlobalInitResult initialise_extrinsic(const FrameStore& store, const std::optional<Iso3>& T_ins_lidar_init,
                                      const GlobalInitConfig& config, std::optional<double> ins_height_m) {
  const auto t0 = Clock::now();
  auto elapsed = [&] { return std::chrono::duration<double>(Clock::now() - t0).count(); };
  const double offset_start_s = store.data().time_offset_init_s.value_or(0.0);
  if (T_ins_lidar_init && config.trust_init) {
    GlobalInitResult result = cannot_start(T_ins_lidar_init, offset_start_s, "", t0);
    result.explanation = "init trusted as given (trust_init): not checked against the data, time offset not searched";
    return result;
  }
  const DriveFrames drive = drive_frames(store);
  if (drive.size() < 4) {
    return cannot_start(T_ins_lidar_init, offset_start_s,
                        "fewer than 4 LiDAR frames lie inside the pose file's time span; no degree of freedom of the "
                        "extrinsic can be determined",
                        t0);
  }
  if (drive.distance_m < 2.0) {
    return cannot_start(T_ins_lidar_init, offset_start_s,
                        fmt::format("the vehicle moves only {:.2f} m over the drive; yaw and the horizontal lever arm of "
                                    "the extrinsic need motion (drive and turn)",
                                    drive.distance_m),
                        t0);
  }
  const InitPlan plan = plan_frames(drive, store.sweep_period_s(), config);
  std::map<std::size_t, InitFrame> loaded = load_frames(store, drive, plan, config);
  GlobalInitResult result;
  result.frames_loaded = static_cast<int>(loaded.size());
  result.load_s = elapsed();

  // 1. Levelling.
  std::vector<InitFrame*> all;
  for (auto& [position, f] : loaded) all.push_back(&f);
  const Levelling level = level_lidar(all, config.ground);
  if (!level.ok) return cannot_start(T_ins_lidar_init, offset_start_s, level.message, t0);
  result.ground_normal_lidar = level.normal_lidar;
  result.lidar_height_m = level.lidar_height_m;
  result.ground_normal_spread_deg = level.normal_spread_deg;
  std::string z_how;
  TzSource data_tz_source = TzSource::kGuess;
  const double height_m =
      ins_height_above_ground(all, store.data().fiducials, config.ins_height_guess_m, ins_height_m, z_how, data_tz_source);
  const double tz_insl_m = level.lidar_height_m - height_m;
  if (T_ins_lidar_init && data_tz_source != TzSource::kFiducials)
    z_how = fmt::format("the data's candidates place the INS {:.2f} m above the ground; the start keeps the init's tz "
                        "({:.3f} m)", height_m, T_ins_lidar_init->translation().z());

  // 2. Coarse yaw on the straight stretch (lever arm irrelevant there).
  std::vector<const InitFrame*> coarse_frames;
  for (std::size_t p : plan.coarse) coarse_frames.push_back(&loaded.at(p));
  const double yaw = coarse_yaw(coarse_frames, level, tz_insl_m, config.crispness_voxel_m, config.coarse);
  result.coarse_yaw_deg = yaw * kDegPerRad;
  result.coarse_s = elapsed() - result.load_s;
  const Iso3 T_coarse = T_ins_lidar_levelled(level, yaw, Eigen::Vector2d::Zero(), tz_insl_m);

  // 3. Planar hand-eye.
  std::vector<std::pair<const InitFrame*, const InitFrame*>> pairs;
  for (const auto& [a, b] : plan.pairs) pairs.push_back({&loaded.at(a), &loaded.at(b)});
  std::vector<MotionPair> motions = register_pairs(pairs, store.poses(), T_coarse, level, config.hand_eye);
  result.time_offset = time_offset_of(motions, store.poses(), config.time_offset, offset_start_s);
  result.time_offset_s = result.time_offset.offset_s;
  if (result.time_offset_s != 0.0) set_ins_motions(motions, store.poses(), level, result.time_offset_s);
  const PlanarHandEyeResult he = solve_planar_hand_eye(motions, tz_insl_m, config.hand_eye);
  result.hand_eye_s = elapsed() - result.load_s - result.coarse_s;
  Iso3 T_data = T_coarse;
  std::string data_how;
  if (he.valid) {
    T_data = T_ins_lidar_levelled(level, he.yaw_rad, he.t_xy_m, tz_insl_m);
    result.hand_eye_pairs_used = static_cast<int>(std::count(he.inlier.begin(), he.inlier.end(), true));
    result.hand_eye_rms_m = he.rms_m;
    result.lever_arm_observed = he.lever_arm_observed;
    data_how = fmt::format("hand-eye over {} of {} registered pairs ({} selected), residual rms {:.3f} m",
                           result.hand_eye_pairs_used, motions.size(), plan.pairs.size(), he.rms_m);
    if (!he.lever_arm_observed) data_how += "; no turns: horizontal lever arm not observed, set to 0";
  } else {
    data_how = fmt::format("hand-eye failed ({} of {} pairs registered): coarse yaw, horizontal lever arm 0",
                           motions.size(), plan.pairs.size());
  }

  // 4. Scores: crispness of the coarse stretch and of every pair.
  std::vector<std::vector<const InitFrame*>> groups = {coarse_frames};
  for (const auto& [a, b] : pairs) groups.push_back({a, b});
  std::vector<InitCandidate> cand =
      make_candidates(T_data, he.valid ? std::optional<Iso3>(T_coarse) : std::nullopt, T_ins_lidar_init, level);
  tbb::parallel_for(std::size_t{0}, cand.size(), [&](std::size_t c) {
    cand[c].score =
        score_candidate(groups, store.poses(), cand[c].T_ins_lidar, result.time_offset_s, config.crispness_voxel_m);
  });
  result.candidates = cand;
  result.score_s = elapsed() - result.load_s - result.coarse_s - result.hand_eye_s;

  std::ostringstream why;
  why << fmt::format("levelled from {} ground planes (normal spread {:.2f} deg, LiDAR {:.2f} m above ground); ",
             level.planes_used, level.normal_spread_deg, level.lidar_height_m)
      << fmt::format("coarse yaw {:.1f} deg by crispness of {} frames over {:.1f} m; ", result.coarse_yaw_deg,
                     plan.coarse.size(), plan.coarse_stretch_m)
      << data_how << "; " << result.time_offset.explanation << "; z: " << z_how << ". Scores (occupied "
      << config.crispness_voxel_m
      << " m voxels, lower is crisper):";
  for (const InitCandidate& c : cand) why << " " << c.label << " " << c.score;
  why << ".";
  decide(cand, T_ins_lidar_init, config, result, why);
  result.tz_source = T_ins_lidar_init ? TzSource::kInit : data_tz_source;
  result.explanation = why.str();
  result.outcome.status = StageStatus::kOk;
  result.outcome.wall_time_s = elapsed();
  return result;
}

}  // namespace insalign
