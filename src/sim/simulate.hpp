// Synthetic calibration drives with ground truth: a seeded scene of analytic primitives, a vehicle
// trajectory, a spinning LiDAR ray-cast from its true pose at every firing instant, and an INS that
// reports noisy poses on its own clock. Everything here is in memory; the CLI writes the files.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/dataset.hpp"
#include "core/geometry.hpp"
#include "core/pose_stream.hpp"
#include "core/sweep.hpp"
#include "sim/ins_error.hpp"
#include "sim/lidar_model.hpp"

namespace insalign::sim {

enum class SceneKind { kIntersection, kFeaturePoor };
/// kFigure8 ... kStandstill: calibration drives; kCityLoop ... kParkingLot: the ordinary drives a
/// fleet makes (sim/drive_plan.hpp), with curves, stops at lights and accelerations.
enum class TrajectoryKind { kFigure8, kStraight, kStandstill, kRecorded, kCityLoop, kUrbanGrid, kHighway, kParkingLot };
/// Axes of the INS body frame relative to the vehicle.
enum class InsAxes {
  kXForward,  ///< ROS REP-103: x forward, y left, z up
  kYForward,  ///< NovAtel sample: x right, y forward, z up
};

struct SimConfig {
  std::uint64_t seed = 1;
  SceneKind scene = SceneKind::kIntersection;
  TrajectoryKind trajectory = TrajectoryKind::kFigure8;
  /// For kRecorded: T_world_ins of a real drive (any INS axes; the forward axis is detected from the
  /// motion). Re-timed to start at the simulation epoch, recentred and lightly smoothed.
  std::vector<StampedPose> recorded_trajectory;
  int figure8_loops = 3;            ///< kFigure8: loops of the figure-8 (~1000 frames at 15 km/h)
  double speed_kmh = 15.0;          ///< cruise speed (kFigure8, kStraight)
  /// Ordinary drives' cruise speed; 0: the kind's own (city-loop and urban-grid 30, highway 90,
  /// parking-lot 10 km/h). Their length is duration_s (0: 180 s).
  double ordinary_speed_kmh = 0.0;
  /// The extrinsic the car believes (installed-extrinsic.json) differs from the truth by this
  /// knock, "dx dy dz droll dpitch dyaw" (m, deg, in the INS frame: truth = knock applied to the
  /// installed one). Zero: the installed extrinsic is the true one.
  Vec6 knock = Vec6::Zero();
  double duration_s = 0;            ///< 0 = the trajectory's natural length; >0 truncates
  std::string lidar_model = "pandar64";  ///< "pandar64", "hdl32", "os1-64", "vlp16", "livox-avia"
  double azimuth_step_deg = 0.2;    ///< horizontal resolution (1800 columns per turn)
  double frame_rate_hz = 10.0;      ///< spin rate; one frame per revolution
  double range_noise_m = 0.02;      ///< Gaussian sigma along the ray
  double dropout_prob = 0.02;       ///< probability that a return is lost
  double max_range_m = 120.0;       ///< no return beyond this
  InsAxes ins_axes = InsAxes::kXForward;
  /// 1 = NovAtel RTK class: position white ~1 cm plus a slow bounded error (Gauss-Markov, 1 cm
  /// horizontal, 1.5 cm vertical, 30 s correlation); attitude white ~0.01 deg roll/pitch,
  /// ~0.03 deg yaw. 0 = perfect poses. Scales the white noise of every INS error model and the
  /// bounded error of kRtkFixed; the drift rates and events of ins_error are absolute.
  double ins_noise_scale = 1.0;
  InsErrorConfig ins_error;         ///< slow error model and events (ins_error.hpp)
  double time_offset_s = 0.0;       ///< t_ins = t_lidar + offset
  std::optional<Iso3> T_ins_lidar;  ///< unset: random roof mount (any yaw, roll/pitch within 10 deg)
  double init_rot_err_deg = 20.0;   ///< rotation error of the written initial guess (random axis)
  double init_trans_err_m = 0.5;    ///< translation error of the initial guess (random direction)
  int n_fiducials = 6;              ///< surveyed ground points
  double fiducial_noise_m = 0.005;  ///< survey noise sigma per axis
  /// Moving vehicles (cars and vans, 15-40 km/h in the lanes 2.2 m either side of the driven
  /// path, keeping right, both directions, straight on and through the turns) and people
  /// (30 % cyclists at 3-6 m/s in the bike lanes at 3.8 m, the others walking at 1-1.8 m/s, some
  /// jogging, along the sidewalks at 5.3 m or crossing). traffic.hpp.
  int traffic = 0;
  int pedestrians = 0;
  /// Several LiDARs (rig.hpp): "name:model[@mount][/rate_hz],...", e.g.
  /// "top:pandar64,left:vlp16@left,right:vlp16@right,front:os1-64@front". Mounts: roof (default),
  /// left, right, front, rear, roof-front; rate: frame_rate_hz unless given. Each rig LiDAR gets
  /// its own seeded mount, clock offset (time_offset_s + U(-rig_clock_spread_s, +spread)), spin
  /// phase and frame phase; the ego body blocks rays (it does not return points). T_ins_lidar, if
  /// given, is the first LiDAR's. Empty: the single LiDAR lidar_model, exactly as without rigs.
  std::string rig;
  double rig_clock_spread_s = 0.03;
};

struct Scene;    // primitives and their BVH (scene.hpp)
struct Traffic;  // moving vehicles and people (traffic.hpp)

/// One simulated LiDAR of the vehicle: model, true mount, its own clock and spin.
struct SimLidar {
  std::string name = "lidar";       ///< a rig LiDAR's folder name
  std::string mount = "roof";       ///< mount preset (rig.hpp)
  LidarModel model;
  Iso3 T_ins_lidar_true = Iso3::Identity();
  Iso3 T_ins_lidar_init = Iso3::Identity();
  Iso3 T_ins_lidar_installed = Iso3::Identity();  ///< what the car believes (SimConfig::knock, first LiDAR)
  double time_offset_s = 0.0;       ///< its clock: t_ins = t_lidar + offset
  double frame_rate_hz = 10.0;
  double start_azimuth_rad = 0.0;   ///< spinning: azimuth of a sweep's first column (clockwise spin)
  std::uint64_t noise_seed = 1;     ///< per-ray noise and dropout
  std::vector<double> frame_times_s;  ///< nominal frame (sweep end) times, its clock
};

/// Everything that does not change from frame to frame. Built once; render_sweep is thread-safe.
/// `lidar`, `T_ins_lidar_true`, `T_ins_lidar_init` and `frame_times_s` are those of lidars[0].
struct World {
  SimConfig config;
  std::vector<SimLidar> lidars;      ///< at least one
  LidarModel lidar;
  std::shared_ptr<const Scene> scene;
  PoseStream poses_true;             ///< true T_world_ins, INS clock, dense (200 Hz)
  Iso3 T_ins_lidar_true = Iso3::Identity();
  Iso3 T_ins_lidar_init = Iso3::Identity();
  std::vector<double> frame_times_s; ///< nominal frame (sweep end) times, LiDAR clock
  std::vector<Fiducial> fiducials;   ///< surveyed (noisy) world points
  double ins_height_m = 0.0;         ///< INS origin height above the ground (mean for kRecorded)
  InsDrift drift;                    ///< kRtkFixed: the bounded position error (empty otherwise)
  InsWalk walk;                      ///< kDrift: the random walk (empty otherwise)
  std::vector<InsEvent> ins_events;  ///< ground truth of the INS events, time order
  Iso3 T_vehicle_ins = Iso3::Identity();   ///< INS axes in the vehicle frame (x forward, z up)
  std::shared_ptr<const Traffic> traffic;  ///< movers (none unless config.traffic/pedestrians)
  std::size_t frame_count() const { return frame_times_s.size(); }
};

/// Builds scene, trajectory, extrinsic and fiducials. Throws std::invalid_argument on a bad config.
World build_world(const SimConfig& config);

/// Frame k of lidars[0]: one revolution ending at frame_times_s[k], each column measured from the
/// sensor's true pose, and the movers where they are, at its own instant; t_end_s = the latest
/// point time; name = frame_name(t_end_s). hit_mover (optional): per point, 1 if it lies on a mover.
Sweep render_sweep(const World& world, std::size_t k, std::vector<std::uint8_t>* hit_mover = nullptr);
/// The same for any LiDAR of the world.
Sweep render_lidar_sweep(const World& world, std::size_t lidar, std::size_t k,
                         std::vector<std::uint8_t>* hit_mover = nullptr);

/// The INS's true slow error at an INS time (model plus events, no white noise): reported
/// position = true + position_m (+ white); reported rotation = Rz Ry Rx(rpy_world_rad) * true.
struct InsSlowError {
  Vec3 position_m = Vec3::Zero();
  Vec3 rpy_world_rad = Vec3::Zero();
};
InsSlowError ins_slow_error(const World& world, double t_ins_s);
/// What the INS states about itself at an INS time (solution type, 1-sigma stddev per horizontal
/// axis and vertical): see event_quality in ins_error.hpp.
InsQuality ins_quality(const World& world, double t_ins_s);
std::vector<InsQuality> ins_quality_series(const World& world, const std::vector<double>& t_ins_s);

/// What the INS reports at the given INS times: truth plus noise (white per sample, drift shared).
/// `stream` separates independent white-noise draws (e.g. per-frame file vs 100 Hz file).
std::vector<StampedPose> reported_poses(const World& world, const std::vector<double>& t_ins_s,
                                        std::uint64_t stream);
/// The per-frame pose file: for each frame time t_end (LiDAR clock) the pose the INS reports for
/// INS time t_end, i.e. the stamp a user without time-offset knowledge pairs with the frame. With a
/// nonzero offset the sweep was actually taken from the pose at INS time t_end + offset.
/// `lidar`: whose pose file (each LiDAR of a rig draws its own white noise; lidars[0]'s is the
/// single-LiDAR file).
std::vector<StampedPose> frame_poses(const World& world, const std::vector<double>& t_end_s, std::size_t lidar = 0);
/// A reported pose stream at rate_hz covering every sweep of every LiDAR (the TUM file).
std::vector<StampedPose> dense_reported_poses(const World& world, double rate_hz = 100.0);

/// "1700000000.100000": the decimal frame time, microseconds.
std::string frame_name(double t_s);

struct SimDataset {                 ///< everything in memory (tests); the CLI streams frames instead
  std::vector<Sweep> sweeps;        ///< raw, motion-distorted; t_end_s = LiDAR clock
  std::vector<std::vector<std::uint8_t>> hit_mover;  ///< per sweep and point: 1 = on a mover
  PoseStream poses;                 ///< reported (noisy) T_world_ins, one per frame, stamped t_end_s (INS clock)
  PoseStream poses_true;            ///< true T_world_ins (dense, for tests)
  Iso3 T_ins_lidar_true = Iso3::Identity(), T_ins_lidar_init = Iso3::Identity();
  double time_offset_s = 0.0;
  std::vector<Fiducial> fiducials;  ///< surveyed (noisy) world points on the ground
  double ins_height_m = 0.0;        ///< true height of the INS origin above the ground plane
  std::vector<InsEvent> ins_events; ///< ground truth of the INS events
  std::vector<InsQuality> ins_quality;  ///< what the INS states, one per pose (frame time, INS clock)
};

/// Renders lidars[0] of a new world (everything in memory).
SimDataset simulate(const SimConfig& config,
                    const std::function<void(std::size_t done, std::size_t total)>& progress = {});
/// Renders one LiDAR of a world: its sweeps, its pose file, its true and initial extrinsic and
/// clock offset (a rig's LiDARs one by one, for in-process tests).
SimDataset simulate_lidar(const World& world, std::size_t lidar,
                          const std::function<void(std::size_t done, std::size_t total)>& progress = {});

/// Core Dataset (FrameSource over the sweeps, reported poses, fiducials, initial guess).
Dataset to_dataset(const SimDataset& sim);

}  // namespace insalign::sim
