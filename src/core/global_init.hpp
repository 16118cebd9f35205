// Global initialisation of the extrinsic: an estimate of T_ins_lidar good enough for stage 1, from
// the data alone (no initial guess), or a check of a user's guess against the data.
//
// Method (assumes only that the pose file's world z is up):
//  1. Levelling (ground_level.hpp): the ground plane below the LiDAR against the INS vertical.
//  2. Coarse yaw (coarse_yaw.hpp): map crispness of a straight stretch over 360 deg.
//  3. Planar hand-eye (hand_eye.hpp): LiDAR scan-to-scan motions against INS motions.
//  4. z is unobservable from planar motion: from fiducials (ground height) if any, else a typical mount.
//  5. Candidates (the data's estimate, it turned by 90/180/270 deg, the coarse one, the init)
//     scored by crispness; with an init, the data overrides it only when clearly better in
//     another basin, and in the init's own basin stage 1 starts from the crisper of the two (a
//     tilted 16-beam side LiDAR's stage 1 ended in a wrong basin from a 20 deg guess that the data's
//     own 0.3 deg estimate beside it avoided).
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "core/coarse_time_offset.hpp"
#include "core/coarse_yaw.hpp"
#include "core/dof_status.hpp"
#include "core/frame_store.hpp"
#include "core/ground_level.hpp"
#include "core/hand_eye.hpp"
#include "core/stage.hpp"

namespace insalign {

struct GlobalInitConfig {
  /// Every loaded frame (min_range_m 0: the vehicle's body radius).
  SweepFilter filter{.min_range_m = 0.0, .max_range_m = 60.0, .voxel_m = 0.3, .max_points = 0};
  GroundConfig ground;
  CoarseYawConfig coarse;
  HandEyeConfig hand_eye;
  CoarseTimeOffsetConfig time_offset;  ///< the LiDAR-to-INS time offset from the hand-eye pairs' angles
  double crispness_voxel_m = 0.5;      ///< voxel of the occupancy count every score uses
  /// INS origin height above the ground when there are no fiducials: an INS in the trunk or cabin
  /// of a car sits about 1 m up (the NovAtel sample: trunk); stage 3 fixes z from fiducials.
  double ins_height_guess_m = 1.0;
  /// The data overrides the init when the init's score (occupied voxels) exceeds the data
  /// candidate's by this factor and the two lie in different basins.
  double override_score_ratio = 1.05;
  double same_basin_rot_deg = 30.0;    ///< closer candidates share stage 1's basin (~20 deg, with margin)...
  double same_basin_trans_m = 1.0;     ///< ...if also this close in translation
  /// An init kept (confirmed by the data) this close to the data's own near start is as near: a
  /// check's installed extrinsic, a previous result given as --init (stage 1 then skips its
  /// one-group rounds, as from the data's start). Horizontal translation: the data's tz is a guess.
  double near_data_rot_deg = 1.0;
  double near_data_trans_m = 0.1;
  bool trust_init = false;             ///< true: return the init unchanged, no checks
};

template <class V>
void visit_config(V& v, GlobalInitConfig& c) {
  v("trust_init", c.trust_init, "true: use --init unchanged, no checks");
  v.section("filter", c.filter);
  v.section("ground", c.ground);
  v.section("coarse", c.coarse);
  v.section("hand_eye", c.hand_eye);
  v.section("time_offset", c.time_offset);
  v("crispness_voxel_m", c.crispness_voxel_m, "voxel of the occupancy count used as a score, m");
  v("ins_height_guess_m", c.ins_height_guess_m, "INS origin height above the ground assumed without fiducials, m");
  v("override_score_ratio", c.override_score_ratio, "the data overrides --init when the init scores this factor worse");
  v("same_basin_rot_deg", c.same_basin_rot_deg, "candidates closer than this share a basin, deg");
  v("same_basin_trans_m", c.same_basin_trans_m, "...if also this close in translation, m");
  v("near_data_rot_deg", c.near_data_rot_deg, "an init kept this close to the data's near start is near too, deg");
  v("near_data_trans_m", c.near_data_trans_m, "...if also this close horizontally, m");
}

/// Where the start for stage 1 came from.
enum class InitSource {
  kData,               ///< no init given: the data's own estimate
  kInit,               ///< the init given, confirmed by the data, trusted, or not checkable
  kDataOverridesInit,  ///< an init was given, but the data clearly prefers another basin
  kDataNearInit,       ///< the init's basin confirmed, but the data's own estimate in it is clearly crisper: that
};
inline constexpr std::array<std::pair<InitSource, std::string_view>, 4> kInitSourceNames{
    {{InitSource::kData, "data"}, {InitSource::kInit, "init"}, {InitSource::kDataOverridesInit, "data-overrides-init"},
     {InitSource::kDataNearInit, "data-near-init"}}};
constexpr auto enum_names(InitSource) { return std::span(kInitSourceNames); }

struct InitCandidate {
  Iso3 T_ins_lidar = Iso3::Identity();
  double score = 0.0;   ///< occupied voxels of the stitched frames (lower is crisper)
  std::string label;    ///< "data", "init", "data-yaw+180", ...
};

struct GlobalInitResult {
  /// kUndetermined: no init was given and the data cannot give a start (message says why).
  StageOutcome outcome;
  Iso3 T_ins_lidar = Iso3::Identity();  ///< the chosen start for stage 1
  /// The time offset stage 1 starts from (t_ins = t_lidar + offset): time_offset.offset_s when the
  /// data showed one far from the given start (a host-stamped LiDAR), else the data set's
  /// time_offset_init_s (a check's installed one) or 0.
  double time_offset_s = 0.0;
  CoarseTimeOffset time_offset;
  InitSource source = InitSource::kData;
  /// Where the start's tz came from: the init whenever one was given (a tape measure beats any
  /// guess, also when the data overrides the init's rotation), else the fiducials' ground height,
  /// --ins-height-m, or the built-in guess (ins_height_guess_m).
  TzSource tz_source = TzSource::kInit;
  std::string start_candidate = "init";  ///< the candidate the start is (its label: "data", "data-yaw+90", ...)
  /// The init was kept within near_data_rot_deg / near_data_trans_m of the "data" candidate.
  bool init_near_data = false;
  std::string explanation;              ///< why: the steps and the scores
  std::vector<InitCandidate> candidates;
  // Diagnostics.
  Vec3 ground_normal_lidar = Vec3::UnitZ();  ///< mean ground normal in the LiDAR frame
  double lidar_height_m = 0.0;               ///< LiDAR origin above the ground plane
  double ground_normal_spread_deg = 0.0;     ///< RMS angle of per-frame normals about the mean
  double coarse_yaw_deg = 0.0;               ///< best yaw of the crispness search
  int hand_eye_pairs_used = 0;
  bool lever_arm_observed = false;           ///< false: no turns, t_xy is a guess (zero)
  double hand_eye_rms_m = 0.0;
  int frames_loaded = 0;
  double load_s = 0.0, coarse_s = 0.0, hand_eye_s = 0.0, score_s = 0.0;  ///< wall time per phase
};

/// The start is the data's planar hand-eye solution with the lever arm observed (a turning drive):
/// within 0.2 deg and 3.5 cm on bench/init_accuracy's drives, far inside stage 1's basin (~20 deg);
/// or an init kept within near_data_rot_deg / near_data_trans_m of that solution. Not so for an
/// init farther from it, a hand-eye solve that failed or a drive without turns.
bool start_is_near(const GlobalInitResult& init);

/// Never throws for degenerate data: without an init, outcome kUndetermined says why the data
/// cannot give a start; with an init the data cannot check, the init is returned (source kInit)
/// and the explanation says why it was not checked. ins_height_m (--ins-height-m): the INS height
/// above the ground the data's tz uses instead of the guess when there are no fiducials.
GlobalInitResult initialise_extrinsic(const FrameStore& store, const std::optional<Iso3>& T_ins_lidar_init,
                                      const GlobalInitConfig& config = {},
                                      std::optional<double> ins_height_m = std::nullopt);

}  // namespace insalign
