#include "sim/simulate.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <mutex>
#include <numbers>
#include <stdexcept>

#include "sim/random.hpp"
#include "sim/rig.hpp"
#include "sim/scene.hpp"
#include "sim/trajectory.hpp"
#include "sim/traffic.hpp"

namespace insalign::sim {
namespace {

constexpr double kPi = std::numbers::pi;
/// LiDAR clock of the start of the motion (INS clock: the same number); frames end 1/rate later.
constexpr double kEpochS = 1700000000.0;
constexpr double kTruthRateHz = 200.0;
// NovAtel-class INS white noise at scale 1 (1 sigma); the slow errors are in ins_error.cpp.
constexpr double kPosWhiteM = 0.01;
// What the INS states for its normal (RTK fixed) solution at scale 1, per axis: the white noise
// and the bounded error together (sqrt(1^2 + 1^2) cm horizontal, sqrt(1^2 + 1.5^2) cm vertical).
constexpr double kStatedHorizontalM = 0.0141;
constexpr double kStatedVerticalM = 0.018;
constexpr double kStatedFloorM = 0.005;  // no INS claims to be exact
constexpr double kRollPitchWhiteDeg = 0.01;
constexpr double kYawWhiteDeg = 0.03;
constexpr std::uint64_t kStreamFramePoses = 1;
constexpr std::uint64_t kStreamDensePoses = 2;

void validate(const SimConfig& c) {
  auto fail = [](const std::string& what) { throw std::invalid_argument(what); };
  if (!(c.azimuth_step_deg >= 0.01 && c.azimuth_step_deg <= 10.0)) fail("azimuth step must be in [0.01, 10] deg");
  if (!(c.frame_rate_hz >= 1.0 && c.frame_rate_hz <= 50.0)) fail("frame rate must be in [1, 50] Hz");
  if (!(c.range_noise_m >= 0.0 && c.range_noise_m <= 1.0)) fail("range noise must be in [0, 1] m");
  if (!(c.dropout_prob >= 0.0 && c.dropout_prob < 1.0)) fail("dropout probability must be in [0, 1)");
  if (!(c.max_range_m >= 5.0 && c.max_range_m <= 1000.0)) fail("max range must be in [5, 1000] m");
  if (!(c.ins_noise_scale >= 0.0 && c.ins_noise_scale <= 1000.0)) fail("INS noise scale must be in [0, 1000]");
  if (!(std::abs(c.time_offset_s) <= 1.0)) fail("time offset must be within +-1 s");
  if (!(c.duration_s >= 0.0 && c.duration_s <= 3600.0)) fail("duration must be in [0, 3600] s");
  if (!(c.speed_kmh > 0.0 && c.speed_kmh <= 120.0)) fail("speed must be in (0, 120] km/h");
  if (c.figure8_loops < 1 || c.figure8_loops > 100) fail("figure-8 loops must be in [1, 100]");
  if (!(c.init_rot_err_deg >= 0.0 && c.init_rot_err_deg <= 180.0)) fail("initial rotation error must be in [0, 180] deg");
  if (!(c.init_trans_err_m >= 0.0 && c.init_trans_err_m <= 100.0)) fail("initial translation error must be in [0, 100] m");
  if (c.n_fiducials < 0 || c.n_fiducials > 1000) fail("fiducial count must be in [0, 1000]");
  if (!(c.fiducial_noise_m >= 0.0 && c.fiducial_noise_m <= 1.0)) fail("fiducial noise must be in [0, 1] m");
  if (c.trajectory == TrajectoryKind::kRecorded && c.recorded_trajectory.size() < 2)
    fail("a recorded trajectory needs at least 2 poses");
  if (c.T_ins_lidar && !c.T_ins_lidar->matrix().allFinite()) fail("given extrinsic is not finite");
  validate_ins_error(c.ins_error);
  if (c.traffic < 0 || c.traffic > 500 || c.pedestrians < 0 || c.pedestrians > 500)
    fail("traffic and pedestrian counts must be in [0, 500]");
  if (!(c.rig_clock_spread_s >= 0.0 && c.rig_clock_spread_s <= 0.5)) fail("rig clock spread must be in [0, 0.5] s");
  if (!c.rig.empty()) parse_rig(c.rig);  // throws naming the bad entry
}

// Random roof mount, physically placed: INS near the rear axle, LiDAR on the roof.
Iso3 random_mount(Rng& rng, double ins_height_m, const Iso3& T_vehicle_ins) {
  const double lidar_height_m = rng.uniform(1.8, 2.2);
  const Vec3 t_vehicle(rng.uniform(0.3, 1.5), rng.uniform(-0.3, 0.3), lidar_height_m - ins_height_m);
  const Vec3 rpy_deg(rng.uniform(-10.0, 10.0), rng.uniform(-10.0, 10.0), rng.uniform(-180.0, 180.0));
  const Iso3 T_vehicle_lidar = make_transform(t_vehicle, rpy_deg);
  return T_vehicle_ins.inverse() * T_vehicle_lidar;
}

// Surveyed ground points beside the path, spread along it, where nothing stands on them.
std::vector<Fiducial> place_fiducials(const SimConfig& c, const Scene& scene, const std::vector<Vec2>& path, Rng& rng) {
  std::vector<Fiducial> out;
  double length = 0.0;
  for (std::size_t i = 1; i < path.size(); ++i) length += (path[i] - path[i - 1]).norm();
  for (int k = 0; k < c.n_fiducials; ++k) {
    for (int attempt = 0; attempt < 50; ++attempt) {
      Vec2 xy;
      if (length < 5.0) {  // standstill: a ring around the vehicle
        const double a = 2 * kPi * (k + 0.5) / c.n_fiducials + rng.normal(0.1);
        xy = path.front() + rng.uniform(5.0, 12.0) * Vec2(std::cos(a), std::sin(a));
      } else {
        const double f = (k + 0.5) / c.n_fiducials + rng.normal(0.02);
        const std::size_t i = std::min(path.size() - 1, static_cast<std::size_t>(std::clamp(f, 0.0, 1.0) * path.size()));
        const Vec2 d = path[std::min(path.size() - 1, i + 1)] - path[i > 0 ? i - 1 : 0];
        const Vec2 n = d.norm() > 1e-9 ? Vec2(-d.y(), d.x()) / d.norm() : Vec2(0, 1);
        xy = path[i] + ((k % 2) ? 1.0 : -1.0) * rng.uniform(2.5, 4.0) * n;
      }
      // Free ground: a ray from above lands on the ground plane itself.
      const double zg = scene.ground.z_at(xy.x(), xy.y());
      const auto hit = scene.cast(Vec3(xy.x(), xy.y(), zg + 30.0), -Vec3::UnitZ(), 100.0);
      if (!hit || std::abs(hit->range_m - 30.0) > 0.01) continue;
      Fiducial f;
      f.id = std::to_string(k + 1);
      f.id.insert(f.id.begin(), 'F');  // not "F" + ...: GCC 12 warns falsely (-Wrestrict)
      f.p_world = Vec3(xy.x(), xy.y(), zg) +
                  Vec3(rng.normal(c.fiducial_noise_m), rng.normal(c.fiducial_noise_m), rng.normal(c.fiducial_noise_m));
      out.push_back(f);
      break;
    }
  }
  return out;
}

// Frame (sweep end) times on a LiDAR's clock: one per period from the start of the motion, the
// first `phase_s` later; as many as the drive holds (or the requested duration).
std::vector<double> frame_times(const SimConfig& c, double rate_hz, double phase_s, double trajectory_s) {
  const double period_s = 1.0 / rate_hz;
  std::size_t n = c.duration_s > 0.0 ? static_cast<std::size_t>(std::llround(c.duration_s * rate_hz))
                                     : static_cast<std::size_t>(std::floor(trajectory_s * rate_hz));
  n = std::max<std::size_t>(1, n);
  std::vector<double> out;
  for (std::size_t k = 0; k < n; ++k) out.push_back(kEpochS + phase_s + (k + 1) * period_s);
  return out;
}

// Initial guess: exactly the requested errors, in random directions (error as CONVENTIONS.md).
Iso3 perturbed(const SimConfig& c, const Iso3& T_true, Rng& rng) {
  const Vec3 axis = rng.unit_vector();
  const Vec3 dir = rng.unit_vector();
  Iso3 T = Iso3::Identity();
  T.linear() = so3_exp(axis * c.init_rot_err_deg * kRadPerDeg) * T_true.linear();
  T.translation() = T_true.translation() + c.init_trans_err_m * dir;
  return T;
}

// The single LiDAR (no rig): a random roof mount unless given, the simulation's own clock offset,
// spinning from behind the sensor, frames on the period grid.
SimLidar single_lidar(const SimConfig& c, double ins_height_m, const Iso3& T_vehicle_ins, double trajectory_s) {
  SimLidar l;
  l.model = lidar_model(c.lidar_model);
  Rng mount_rng(hash_counters(c.seed, 0x3057));
  l.T_ins_lidar_true = c.T_ins_lidar ? *c.T_ins_lidar : random_mount(mount_rng, ins_height_m, T_vehicle_ins);
  l.T_ins_lidar_init = perturbed(c, l.T_ins_lidar_true, mount_rng);
  l.time_offset_s = c.time_offset_s;
  l.frame_rate_hz = c.frame_rate_hz;
  l.start_azimuth_rad = kPi;
  l.noise_seed = c.seed;
  l.frame_times_s = frame_times(c, c.frame_rate_hz, 0.0, trajectory_s);
  return l;
}

// Rig LiDARs: each its own mount (preset, randomised), clock offset, spin phase and frame phase,
// all from its own random stream so adding a LiDAR does not move the others.
std::vector<SimLidar> rig_lidars(const SimConfig& c, double ins_height_m, const Iso3& T_vehicle_ins, double trajectory_s) {
  std::vector<SimLidar> out;
  const std::vector<RigLidarSpec> specs = parse_rig(c.rig);
  for (std::size_t i = 0; i < specs.size(); ++i) {
    Rng rng(hash_counters(c.seed, 0x716, i));
    SimLidar l;
    l.name = specs[i].name;
    l.mount = specs[i].mount;
    l.model = lidar_model(specs[i].model);
    const Iso3 T_vehicle_lidar = random_vehicle_mount(specs[i].mount, rng, ins_height_m);
    l.T_ins_lidar_true = i == 0 && c.T_ins_lidar ? *c.T_ins_lidar : T_vehicle_ins.inverse() * T_vehicle_lidar;
    l.T_ins_lidar_init = perturbed(c, l.T_ins_lidar_true, rng);
    l.time_offset_s = c.time_offset_s + rng.uniform(-c.rig_clock_spread_s, c.rig_clock_spread_s);
    l.frame_rate_hz = specs[i].frame_rate_hz > 0.0 ? specs[i].frame_rate_hz : c.frame_rate_hz;
    l.start_azimuth_rad = rng.uniform(-kPi, kPi);
    const double phase_s = rng.uniform(0.0, 1.0 / l.frame_rate_hz);
    l.noise_seed = hash_counters(c.seed, 0x716, i, 1);
    l.frame_times_s = frame_times(c, l.frame_rate_hz, phase_s, trajectory_s);
    out.push_back(std::move(l));
  }
  return out;
}

// Movers around the driven path, avoiding the ego's body (EgoBody) over the whole drive.
Traffic build_traffic(const World& w, const std::vector<Vec2>& path_xy) {
  TrafficRequest request;
  request.vehicles = w.config.traffic;
  request.people = w.config.pedestrians;
  request.path_xy = path_xy;
  request.t_begin_s = kEpochS;
  request.t_end_s = kEpochS;  // the last sweep of any LiDAR, on the INS clock
  for (const SimLidar& l : w.lidars) request.t_end_s = std::max(request.t_end_s, l.frame_times_s.back() + std::abs(l.time_offset_s));
  request.seed = hash_counters(w.config.seed, 0x7AFF1C);
  EgoFootprint ego;
  const Iso3 T_ins_vehicle = w.T_vehicle_ins.inverse();
  const Box body = EgoBody::box(w.ins_height_m);
  ego.half_m = body.half_m.head<2>();
  ego.pose = [&w, T_ins_vehicle, body](double t_s) {
    const double t = std::clamp(t_s, w.poses_true.t_begin(), w.poses_true.t_end());
    const Iso3 T_world_vehicle = w.poses_true.T_world_ins(t) * T_ins_vehicle;
    const Vec3 c = T_world_vehicle * Vec3(body.center_m.x(), 0.0, 0.0);
    const Vec3 x = T_world_vehicle.linear().col(0);
    return MoverPose{c.head<2>(), std::atan2(x.y(), x.x())};
  };
  return make_traffic(request, *w.scene, ego);
}

// The INS error of the configured model and its events, each from its own random stream.
void build_ins_error(World& w) {
  const SimConfig& c = w.config;
  if (c.ins_error.model == InsErrorModel::kRtkFixed) {
    w.drift = make_rtk_fixed_drift(c.ins_noise_scale, w.poses_true.t_begin(), w.poses_true.t_end(),
                                   hash_counters(c.seed, 0xD21F7));
  } else {
    // Exact at the start of the first sweep, walking from there.
    w.walk = make_walk(c.ins_error, kEpochS, w.poses_true.t_end(), hash_counters(c.seed, 0x3A1C));
  }
  w.ins_events = place_ins_events(c.ins_error, kEpochS, w.frame_times_s.back(), hash_counters(c.seed, 0xE7E47));
}

}  // namespace


std::string frame_name(double t_s) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.6f", t_s);
  return buf;
}

// Ordinary drives pass far more street than a figure-8: their scene holds as much per metre.
double scene_density(const Trajectory& trajectory) {
  if (!trajectory.ordinary()) return 1.0;
  return std::clamp(static_cast<double>(trajectory.loop_xy().size()) * 0.05 / 250.0, 1.0, 12.0);
}

// The extrinsic a car believes after a knock (truth = knock applied to it, in the INS frame).
Iso3 knocked_back(const Iso3& T_true, const Vec6& knock) {
  Iso3 T = T_true;
  T.linear() = rotation_from_rpy(knock.tail<3>() * kRadPerDeg).transpose() * T_true.linear();
  T.translation() = T_true.translation() - knock.head<3>();
  return T;
}

World build_world(const SimConfig& config) {
  validate(config);
  World w;
  w.config = config;
  Rng rng(config.seed);
  const Trajectory trajectory(config, rng);
  const Iso3 T_vehicle_ins = vehicle_from_ins(config.ins_axes);
  w.ins_height_m = trajectory.ins_height_m();

  w.lidars = config.rig.empty() ? std::vector<SimLidar>{single_lidar(config, w.ins_height_m, T_vehicle_ins, trajectory.duration_s())}
                                : rig_lidars(config, w.ins_height_m, T_vehicle_ins, trajectory.duration_s());
  for (SimLidar& l : w.lidars) l.T_ins_lidar_installed = l.T_ins_lidar_true;
  w.lidars.front().T_ins_lidar_installed = knocked_back(w.lidars.front().T_ins_lidar_true, config.knock);
  const SimLidar& first = w.lidars.front();
  w.lidar = first.model;
  w.T_ins_lidar_true = first.T_ins_lidar_true;
  w.T_ins_lidar_init = first.T_ins_lidar_init;
  w.frame_times_s = first.frame_times_s;

  // Truth on the INS clock, dense, covering every sweep through the offset with a margin.
  double max_offset_s = 0.0, t_last = kEpochS + trajectory.duration_s();
  for (const SimLidar& l : w.lidars) {
    max_offset_s = std::max(max_offset_s, std::abs(l.time_offset_s));
    t_last = std::max(t_last, l.frame_times_s.back());
  }
  const double pad_s = 1.0 + max_offset_s;
  const long long i0 = static_cast<long long>(std::floor(-pad_s * kTruthRateHz));
  const long long i1 = static_cast<long long>(std::ceil((t_last - kEpochS + pad_s) * kTruthRateHz));
  std::vector<StampedPose> truth;
  truth.reserve(static_cast<std::size_t>(i1 - i0 + 1));
  for (long long i = i0; i <= i1; ++i) {
    const double tau = static_cast<double>(i) / kTruthRateHz;
    truth.push_back({kEpochS + tau, trajectory.T_world_vehicle(tau) * T_vehicle_ins});
  }
  w.poses_true = PoseStream(std::move(truth));

  w.scene = std::make_shared<const Scene>(make_scene(config.scene, config.seed, trajectory.loop_xy(), trajectory.ground(),
                                                          scene_density(trajectory)));
  w.T_vehicle_ins = T_vehicle_ins;
  w.traffic = std::make_shared<const Traffic>(build_traffic(w, trajectory.loop_xy()));

  Rng fid_rng(hash_counters(config.seed, 0xF1D));
  w.fiducials = place_fiducials(config, *w.scene, trajectory.loop_xy(), fid_rng);

  build_ins_error(w);
  return w;
}

InsSlowError ins_slow_error(const World& world, double t_ins_s) {
  InsSlowError e;
  if (world.config.ins_error.model == InsErrorModel::kRtkFixed) {
    e.position_m = world.drift.at(t_ins_s);
  } else {
    e.position_m = world.walk.position.at(t_ins_s);
    e.rpy_world_rad.z() = world.walk.heading_at(t_ins_s);
  }
  for (const InsEvent& event : world.ins_events) {
    if (t_ins_s < event.t_begin_s || t_ins_s >= event.t_end_s) continue;
    e.position_m += event_position_error(event, t_ins_s);
    e.rpy_world_rad += event_rpy_error_rad(event, t_ins_s);
  }
  return e;
}

InsQuality ins_quality(const World& world, double t_ins_s) {
  const SimConfig& c = world.config;
  double h = c.ins_noise_scale * kStatedHorizontalM, v = c.ins_noise_scale * kStatedVerticalM;
  if (c.ins_error.model == InsErrorModel::kDrift) {
    // White noise plus the walk's 1 sigma so far: an honest INS knows it is drifting.
    const double dt = std::max(0.0, t_ins_s - kEpochS);
    const double white = c.ins_noise_scale * kPosWhiteM;
    h = std::sqrt(white * white + std::pow(c.ins_error.drift_horizontal_m_per_sqrt_s, 2) * dt);
    v = std::sqrt(white * white + std::pow(c.ins_error.drift_vertical_m_per_sqrt_s, 2) * dt);
  }
  return event_quality(world.ins_events, t_ins_s, std::max(kStatedFloorM, h), std::max(kStatedFloorM, v));
}

std::vector<InsQuality> ins_quality_series(const World& world, const std::vector<double>& t_ins_s) {
  std::vector<InsQuality> out;
  out.reserve(t_ins_s.size());
  for (double t : t_ins_s) out.push_back(ins_quality(world, t));
  return out;
}

std::vector<StampedPose> reported_poses(const World& world, const std::vector<double>& t_ins_s, std::uint64_t stream) {
  const double scale = world.config.ins_noise_scale;
  const bool rtk_fixed = world.config.ins_error.model == InsErrorModel::kRtkFixed;
  std::vector<StampedPose> out;
  out.reserve(t_ins_s.size());
  for (std::size_t i = 0; i < t_ins_s.size(); ++i) {
    const double t = t_ins_s[i];
    Iso3 T = world.poses_true.T_world_ins(t);
    // RTK fixed at scale 0 is exact (the bounded error scales with the white noise).
    const InsSlowError e = rtk_fixed && scale <= 0.0 && world.ins_events.empty() ? InsSlowError{} : ins_slow_error(world, t);
    if (scale > 0.0) {
      const std::uint64_t key = hash_counters(world.config.seed, 0xA11 + stream, i);
      double g[6];
      for (int q = 0; q < 6; ++q) g[q] = normal_from_bits(splitmix64(key ^ (2 * q + 1)), splitmix64(key ^ (2 * q + 2)));
      T.translation() += e.position_m + scale * kPosWhiteM * Vec3(g[0], g[1], g[2]);
      const Vec3 rpy_deg = scale * Vec3(kRollPitchWhiteDeg * g[3], kRollPitchWhiteDeg * g[4], kYawWhiteDeg * g[5]);
      T.linear() = T.linear() * rotation_from_rpy(rpy_deg * kRadPerDeg);
    } else if (!e.position_m.isZero(0.0)) {
      T.translation() += e.position_m;
    }
    if (!e.rpy_world_rad.isZero(0.0)) T.linear() = rotation_from_rpy(e.rpy_world_rad) * T.linear();
    out.push_back({t, T});
  }
  return out;
}

std::vector<StampedPose> frame_poses(const World& world, const std::vector<double>& t_end_s, std::size_t lidar) {
  // Each LiDAR's pose file draws its own white noise (the first one's as before rigs existed).
  return reported_poses(world, t_end_s, lidar == 0 ? kStreamFramePoses : kStreamFramePoses + 0x100 * lidar);
}

std::vector<StampedPose> dense_reported_poses(const World& world, double rate_hz) {
  double lo = world.poses_true.t_end(), hi = world.poses_true.t_begin();
  for (const SimLidar& l : world.lidars) {  // every sweep of every LiDAR, through its offset
    const double period_s = 1.0 / l.frame_rate_hz;
    const double margin_s = std::abs(l.time_offset_s) + 0.2;
    lo = std::min(lo, std::max(world.poses_true.t_begin(), l.frame_times_s.front() - period_s - margin_s));
    hi = std::max(hi, std::min(world.poses_true.t_end(), l.frame_times_s.back() + margin_s));
  }
  std::vector<double> times;
  for (long long i = static_cast<long long>(std::ceil(lo * rate_hz)); static_cast<double>(i) / rate_hz <= hi; ++i)
    times.push_back(static_cast<double>(i) / rate_hz);
  return reported_poses(world, times, kStreamDensePoses);
}

SimDataset simulate_lidar(const World& world, std::size_t lidar, const std::function<void(std::size_t, std::size_t)>& progress) {
  const SimLidar& l = world.lidars.at(lidar);
  SimDataset out;
  const std::size_t n = l.frame_times_s.size();
  out.sweeps.resize(n);
  out.hit_mover.resize(n);
  std::atomic<std::size_t> done{0};
  std::mutex progress_mutex;
  tbb::parallel_for(std::size_t{0}, n, [&](std::size_t k) {
    out.sweeps[k] = render_lidar_sweep(world, lidar, k, &out.hit_mover[k]);
    const std::size_t d = ++done;
    if (progress) {
      std::lock_guard<std::mutex> lock(progress_mutex);
      progress(d, n);
    }
  });
  std::vector<double> t_end;
  for (const Sweep& s : out.sweeps) t_end.push_back(s.t_end_s);
  out.poses = PoseStream(frame_poses(world, t_end, lidar));
  out.poses_true = world.poses_true;
  out.T_ins_lidar_true = l.T_ins_lidar_true;
  out.T_ins_lidar_init = l.T_ins_lidar_init;
  out.time_offset_s = l.time_offset_s;
  out.fiducials = world.fiducials;
  out.ins_height_m = world.ins_height_m;
  out.ins_events = world.ins_events;
  out.ins_quality = ins_quality_series(world, t_end);
  return out;
}

SimDataset simulate(const SimConfig& config, const std::function<void(std::size_t, std::size_t)>& progress) {
  return simulate_lidar(build_world(config), 0, progress);
}

Dataset to_dataset(const SimDataset& sim) {
  Dataset d;
  d.frames = frame_source_from(sim.sweeps);
  d.poses = sim.poses;
  d.fiducials = sim.fiducials;
  d.T_ins_lidar_init = sim.T_ins_lidar_init;
  d.ins_quality = sim.ins_quality;
  return d;
}

}  // namespace insalign::sim
