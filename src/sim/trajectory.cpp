#include "sim/trajectory.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>

namespace insalign::sim {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kPathStepM = 0.05;
// Body roll per lateral acceleration and pitch per longitudinal acceleration of a passenger car
// (about 6 deg/g roll, 5 deg/g pitch): 15 km/h on a 15 m radius gives ~0.7 deg of roll.
constexpr double kRollRadPerMps2 = 0.6 * kRadPerDeg;
constexpr double kPitchRadPerMps2 = 0.5 * kRadPerDeg;
constexpr double kStraightLengthM = 250.0;
constexpr double kStandstillS = 20.0;

double wrap_pi(double a) {
  while (a > kPi) a -= 2 * kPi;
  while (a < -kPi) a += 2 * kPi;
  return a;
}

// One loop of the lemniscate x = A sin u, y = B/2 sin 2u, resampled every kPathStepM of arc length.
std::vector<Vec2> figure8_table(double A, double B, double& loop_length_m) {
  const int n = 40000;
  std::vector<double> s_of(n + 1, 0.0);
  std::vector<Vec2> fine(n + 1);
  for (int i = 0; i <= n; ++i) {
    const double u = 2 * kPi * i / n;
    fine[i] = Vec2(A * std::sin(u), 0.5 * B * std::sin(2 * u));
    if (i > 0) s_of[i] = s_of[i - 1] + (fine[i] - fine[i - 1]).norm();
  }
  loop_length_m = s_of[n];
  std::vector<Vec2> xy;
  for (double s = 0.0; s < loop_length_m; s += kPathStepM) {
    const auto it = std::upper_bound(s_of.begin(), s_of.end(), s);
    const std::size_t i = std::clamp<std::size_t>(it - s_of.begin(), 1, n);
    const double f = (s - s_of[i - 1]) / std::max(1e-12, s_of[i] - s_of[i - 1]);
    xy.push_back(fine[i - 1] + f * (fine[i] - fine[i - 1]));
  }
  return xy;
}

}  // namespace

Iso3 vehicle_from_ins(InsAxes axes) {
  Iso3 T_vehicle_ins = Iso3::Identity();
  // NovAtel: INS x = vehicle right (-y), INS y = vehicle forward (x): a -90 deg yaw.
  if (axes == InsAxes::kYForward) T_vehicle_ins.linear() = rotation_from_rpy(Vec3(0, 0, -kPi / 2));
  return T_vehicle_ins;
}

Trajectory::Trajectory(const SimConfig& config, Rng& rng) : kind_(config.trajectory) {
  ins_height_m_ = rng.uniform(0.5, 1.0);
  const double slope_max = config.scene == SceneKind::kIntersection ? 0.01 : 0.005;
  const double slope = rng.uniform(0.0, slope_max), slope_dir = rng.uniform(-kPi, kPi);
  ground_ = {0.0, slope * std::cos(slope_dir), slope * std::sin(slope_dir)};
  const double yaw0 = rng.uniform(-kPi, kPi);
  if (kind_ == TrajectoryKind::kRecorded) {
    init_recorded(config.recorded_trajectory);
    return;
  }
  if (kind_ == TrajectoryKind::kCityLoop || kind_ == TrajectoryKind::kUrbanGrid || kind_ == TrajectoryKind::kHighway ||
      kind_ == TrajectoryKind::kParkingLot) {
    init_ordinary(config, rng, yaw0);
    return;
  }
  init_analytic(config, rng, yaw0);
}

void Trajectory::init_ordinary(const SimConfig& config, Rng& rng, double yaw0) {
  const double duration_s = config.duration_s > 0.0 ? config.duration_s : 180.0;
  const DrivePlan plan = ordinary_plan(kind_, config.ordinary_speed_kmh, duration_s, kPathStepM);
  const Eigen::Rotation2Dd rot(yaw0);
  table_.clear();
  for (const PathPoint& q : plan.loop) {
    const Vec2 xy = rot * Vec2(q.x, q.y);
    table_.push_back({xy.x(), xy.y(), q.heading_rad + yaw0, q.curvature_per_m});
    loop_xy_.push_back(xy);
  }
  closed_ = plan.closed;
  loop_length_m_ = static_cast<double>(table_.size()) * kPathStepM;
  profile_ = plan_speed(plan, duration_s, kPathStepM, rng);
  total_length_m_ = profile_.s_m.back();
  cruise_mps_ = plan.cruise_mps;
  duration_s_ = std::min(duration_s, profile_.duration_s());
}

void Trajectory::init_recorded(const std::vector<StampedPose>& in) {
  if (in.size() < 2) throw std::invalid_argument("recorded trajectory needs at least 2 poses");
  const double t0 = in.front().t_s;
  const Vec3 p0 = in.front().T_world_ins.translation();
  // Light smoothing of positions (5-sample moving average) removes the INS's own jitter.
  std::vector<Vec3> p(in.size());
  for (std::size_t i = 0; i < in.size(); ++i) {
    // Symmetric window, shrinking at the ends so the first and last poses stay put.
    const std::size_t half = std::min<std::size_t>({2, i, in.size() - 1 - i});
    Vec3 sum = Vec3::Zero();
    int n = 0;
    for (std::size_t j = i - half; j <= i + half; ++j, ++n) sum += in[j].T_world_ins.translation() - p0;
    p[i] = sum / n;
  }
  // Which body axis points forward: the mean direction of motion in the body frame.
  Vec3 v_body = Vec3::Zero();
  for (std::size_t i = 1; i + 1 < in.size(); ++i) {
    const Vec3 dp = p[i + 1] - p[i - 1];
    const double dt = in[i + 1].t_s - in[i - 1].t_s;
    if (dt > 0 && dp.norm() / dt > 0.5) v_body += in[i].T_world_ins.linear().transpose() * dp.normalized();
  }
  Mat3 R_ins_vehicle = Mat3::Identity();
  if (v_body.head<2>().norm() > 1e-6) {
    Vec3 fwd = Vec3::Zero();
    int axis = std::abs(v_body.x()) >= std::abs(v_body.y()) ? 0 : 1;
    fwd[axis] = v_body[axis] > 0 ? 1.0 : -1.0;
    const Vec3 up = Vec3::UnitZ();
    R_ins_vehicle.col(0) = fwd;
    R_ins_vehicle.col(1) = up.cross(fwd);
    R_ins_vehicle.col(2) = up;
  }
  std::vector<StampedPose> vehicle;
  for (std::size_t i = 0; i < in.size(); ++i) {
    Iso3 T = Iso3::Identity();
    T.linear() = in[i].T_world_ins.linear() * R_ins_vehicle;
    T.translation() = p[i];
    vehicle.push_back({in[i].t_s - t0, T});
    loop_xy_.push_back(p[i].head<2>());
  }
  recorded_ = PoseStream(std::move(vehicle));
  duration_s_ = recorded_.t_end();
  // Ground: the plane through the drive, lowered by the INS height.
  Eigen::MatrixXd A(in.size(), 3);
  Eigen::VectorXd b(in.size());
  for (std::size_t i = 0; i < in.size(); ++i) {
    A.row(i) << 1.0, p[i].x(), p[i].y();
    b(i) = p[i].z() - ins_height_m_;
  }
  const Eigen::Vector3d g = A.colPivHouseholderQr().solve(b);
  ground_ = {g(0), g(1), g(2)};
}

void Trajectory::init_analytic(const SimConfig& config, Rng& rng, double yaw0) {
  const Eigen::Rotation2Dd rot(yaw0);
  // Analytic paths as a table of one loop, centred on the origin and rotated by yaw0.
  std::vector<Vec2> xy;
  int loops = 1;
  if (kind_ == TrajectoryKind::kFigure8) {
    // Lemniscate of Gerono x = A sin u, y = B/2 sin 2u: curvature smooth, zero at the crossing,
    // largest (A / B^2, ~15 m radius) at the tips.
    const double A = rng.uniform(27.0, 33.0);
    xy = figure8_table(A, 0.7 * A, loop_length_m_);
    loops = std::max(1, config.figure8_loops);
  } else if (kind_ == TrajectoryKind::kStraight) {
    loop_length_m_ = kStraightLengthM;
    for (double s = 0.0; s <= loop_length_m_; s += kPathStepM) xy.push_back(Vec2(s - 0.5 * loop_length_m_, 0.0));
  } else {
    loop_length_m_ = 0.0;
    xy = {Vec2::Zero(), Vec2(kPathStepM, 0.0)};
  }
  for (Vec2& q : xy) q = rot * q;
  // Heading and curvature by central differences along the table.
  const std::size_t m = xy.size();
  const bool closed = kind_ == TrajectoryKind::kFigure8;
  closed_ = closed;
  table_.resize(m);
  for (std::size_t i = 0; i < m; ++i) {
    const std::size_t a = closed ? (i + m - 1) % m : (i == 0 ? 0 : i - 1);
    const std::size_t b = closed ? (i + 1) % m : std::min(m - 1, i + 1);
    const Vec2 d = xy[b] - xy[a];
    table_[i] = {xy[i].x(), xy[i].y(), std::atan2(d.y(), d.x()), 0.0};
  }
  for (std::size_t i = 0; i < m; ++i) {
    if (!closed && (i == 0 || i + 1 == m)) continue;
    const std::size_t a = (i + m - 1) % m, b = (i + 1) % m;
    table_[i].curvature_per_m = wrap_pi(table_[b].heading_rad - table_[a].heading_rad) / (2 * kPathStepM);
  }
  if (kind_ == TrajectoryKind::kStandstill) table_[0].heading_rad = table_[1].heading_rad = yaw0;
  for (const PathSample& q : table_) loop_xy_.push_back(Vec2(q.x, q.y));

  total_length_m_ = loops * loop_length_m_;
  cruise_mps_ = kind_ == TrajectoryKind::kStandstill ? 0.0 : config.speed_kmh / 3.6;
  if (cruise_mps_ > 0.0) {
    ramp_s_ = std::min(3.0, total_length_m_ / cruise_mps_);
    duration_s_ = total_length_m_ / cruise_mps_ + ramp_s_;
  } else {
    duration_s_ = kStandstillS;
  }
}

Trajectory::PathSample Trajectory::path_at(double s_m) const {
  if (table_.size() < 2 || loop_length_m_ <= 0.0) return table_.front();
  const bool closed = closed_;
  double s = closed ? std::fmod(s_m, loop_length_m_) : std::clamp(s_m, 0.0, loop_length_m_);
  if (s < 0) s += loop_length_m_;
  const double fi = s / kPathStepM;
  std::size_t i = static_cast<std::size_t>(fi);
  if (i >= table_.size()) i = table_.size() - 1;
  const std::size_t j = closed ? (i + 1) % table_.size() : std::min(table_.size() - 1, i + 1);
  const double f = std::clamp(fi - static_cast<double>(i), 0.0, 1.0);
  const PathSample& a = table_[i];
  const PathSample& b = table_[j];
  return {a.x + f * (b.x - a.x), a.y + f * (b.y - a.y), a.heading_rad + f * wrap_pi(b.heading_rad - a.heading_rad),
          a.curvature_per_m + f * (b.curvature_per_m - a.curvature_per_m)};
}

void Trajectory::speed_at(double tau, double& s, double& v, double& a) const {
  // Smooth (raised-cosine) start and stop ramps around a constant cruise speed.
  if (!profile_.t_s.empty()) {
    s = profile_.s_at(tau, v, a);
    return;
  }
  const double v0 = cruise_mps_, T = ramp_s_, L = total_length_m_;
  s = v = a = 0.0;
  if (v0 <= 0.0 || tau <= 0.0) return;
  const double t_brake = L / v0;  // cruise ends here; the stop ramp takes T more
  if (tau < T) {
    v = 0.5 * v0 * (1 - std::cos(kPi * tau / T));
    s = 0.5 * v0 * (tau - T / kPi * std::sin(kPi * tau / T));
    a = 0.5 * v0 * kPi / T * std::sin(kPi * tau / T);
  } else if (tau < t_brake) {
    v = v0;
    s = 0.5 * v0 * T + v0 * (tau - T);
  } else if (tau < t_brake + T) {
    const double u = tau - t_brake;
    v = 0.5 * v0 * (1 + std::cos(kPi * u / T));
    s = L - 0.5 * v0 * T + 0.5 * v0 * (u + T / kPi * std::sin(kPi * u / T));
    a = -0.5 * v0 * kPi / T * std::sin(kPi * u / T);
  } else {
    s = L;
  }
}

Iso3 Trajectory::T_world_vehicle(double tau_s) const {
  if (kind_ == TrajectoryKind::kRecorded) {
    return recorded_.T_world_ins(std::clamp(tau_s, recorded_.t_begin(), recorded_.t_end()));
  }
  double s = 0, v = 0, a = 0;
  speed_at(tau_s, s, v, a);
  const PathSample q = path_at(s);
  const double c = std::cos(q.heading_rad), sn = std::sin(q.heading_rad);
  const double slope_along = ground_.slope_x * c + ground_.slope_y * sn;
  const double slope_left = -ground_.slope_x * sn + ground_.slope_y * c;
  // Uphill lifts the nose (negative pitch about y-left); the body rolls away from the turn centre.
  const double roll = std::atan(slope_left) + kRollRadPerMps2 * v * v * q.curvature_per_m;
  const double pitch = -std::atan(slope_along) - kPitchRadPerMps2 * a;
  Iso3 T = Iso3::Identity();
  T.linear() = rotation_from_rpy(Vec3(roll, pitch, q.heading_rad));
  T.translation() = Vec3(q.x, q.y, ground_.z_at(q.x, q.y) + ins_height_m_);
  return T;
}

}  // namespace insalign::sim
