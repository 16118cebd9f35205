#include "core/ins_screen.hpp"

#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <optional>

#include <Eigen/Eigenvalues>
#include <fmt/format.h>

#include "core/deskew.hpp"
#include "core/stats.hpp"
#include "core/voxel_grid.hpp"

namespace insalign {
namespace {

constexpr double kEps_s = 1e-3;
constexpr double kPeriodSlack = 1.1;  // a sweep spans a little more than its period (frames.cpp)

// ---- INS status -------------------------------------------------------------------------------

// Worse solutions rank higher; kUnknown says nothing (-1).
int solution_rank(GnssSolution s) {
  switch (s) {
    case GnssSolution::kRtkFixed: return 0;
    case GnssSolution::kRtkFloat: return 1;
    case GnssSolution::kDifferential: return 2;
    case GnssSolution::kSingle: return 3;
    case GnssSolution::kInsOnly: return 4;
    case GnssSolution::kInvalid: return 5;
    default: return -1;
  }
}

const char* solution_words(int rank) {
  static const char* names[] = {"RTK fixed", "RTK float", "differential", "single point", "INS only (no GNSS)",
                                "invalid"};
  return rank >= 0 && rank <= 5 ? names[rank] : "unknown";
}

struct StatusTypical {
  int rank = -1;
  double stddev_m = std::numeric_limits<double>::quiet_NaN();
};

StatusTypical typical_status(const std::vector<InsQuality>& quality) {
  std::vector<double> ranks, sigmas;
  for (const InsQuality& q : quality) {
    if (solution_rank(q.solution) >= 0) ranks.push_back(solution_rank(q.solution));
    if (std::isfinite(q.horizontal_stddev_m)) sigmas.push_back(q.horizontal_stddev_m);
  }
  StatusTypical t;
  if (!ranks.empty()) {  // the lower middle: an even split between two classes counts as the better
    std::sort(ranks.begin(), ranks.end());
    t.rank = static_cast<int>(ranks[(ranks.size() - 1) / 2]);
  }
  t.stddev_m = median(sigmas);
  return t;
}

std::optional<SpanKind> status_kind(const InsQuality& q, const StatusTypical& typical, double stddev_limit_m) {
  const int rank = solution_rank(q.solution);
  if (typical.rank >= 0 && rank > typical.rank) {
    if (q.solution == GnssSolution::kInvalid) return SpanKind::kInvalid;
    return q.solution == GnssSolution::kInsOnly ? SpanKind::kInsOnly : SpanKind::kDegradedFix;
  }
  if (std::isfinite(q.horizontal_stddev_m) && q.horizontal_stddev_m > stddev_limit_m) return SpanKind::kLargeStddev;
  return std::nullopt;
}

std::string status_reason(const std::vector<InsQuality>& q, std::size_t first, std::size_t last,
                          const StatusTypical& typical) {
  double worst = 0.0;
  int rank = -1;
  for (std::size_t i = first; i <= last; ++i) {
    if (std::isfinite(q[i].horizontal_stddev_m)) worst = std::max(worst, q[i].horizontal_stddev_m);
    rank = std::max(rank, solution_rank(q[i].solution));
  }
  std::string s = fmt::format("the INS reports {} (usual: {})", solution_words(rank), solution_words(typical.rank));
  if (worst > 0.0) s += fmt::format(", stated horizontal stddev up to {:.3f} m (typical {:.3f} m)", worst, typical.stddev_m);
  return s;
}

// ---- Frames placed with the extrinsic ---------------------------------------------------------

struct PlacedFrame {
  bool ok = false;
  double t_s = 0.0;                  // INS clock, frame time
  Iso3 T_world_lidar = Iso3::Identity();
  std::vector<Vec3> p_lidar;         // deskewed to the frame time
  Vec3 velocity_mps = Vec3::Zero();  // of the INS, world
};

std::vector<PlacedFrame> place_frames(const FrameStore& store, const std::vector<std::size_t>& frames,
                                      const Iso3& T_ins_lidar, double time_offset_s, const SweepFilter& filter) {
  const std::vector<Sweep> sweeps = store.thinned(frames, filter);
  const PoseStream& poses = store.poses();
  std::vector<PlacedFrame> out(frames.size());
  tbb::parallel_for(std::size_t{0}, frames.size(), [&](std::size_t k) {
    const Sweep& sweep = sweeps[k];
    PlacedFrame& f = out[k];
    const double t = sweep.t_end_s + time_offset_s;
    if (sweep.size() < 50 || !sweep_covered(poses, sweep, time_offset_s) || !poses.covers(t - 0.05)) return;
    const std::vector<Vec3f> p = deskew_sweep(sweep, poses, T_ins_lidar, PlaceOptions{.time_offset_s = time_offset_s});
    f.p_lidar.reserve(p.size());
    for (const Vec3f& q : p) f.p_lidar.push_back(q.cast<double>());
    f.t_s = t;
    f.T_world_lidar = poses.T_world_ins(t) * T_ins_lidar;
    f.velocity_mps = (poses.T_world_ins(t).translation() - poses.T_world_ins(t - 0.05).translation()) / 0.05;
    f.ok = true;
  });
  std::erase_if(out, [](const PlacedFrame& f) { return !f.ok; });
  return out;
}

// ---- Scan-to-scan -----------------------------------------------------------------------------

// A chain along the drive: each pair's second frame is the next pair's first; a hole of more than
// two gaps restarts it.
std::vector<std::pair<std::size_t, std::size_t>> chain_pairs(const std::vector<PlacedFrame>& f,
                                                             const LidarMotionConfig& c) {
  std::vector<std::pair<std::size_t, std::size_t>> pairs;
  if (f.size() < 2) return pairs;
  const double gap = std::max(c.min_gap_s, (f.back().t_s - f.front().t_s) / std::max<double>(c.max_pairs, 1));
  std::size_t a = 0;
  for (std::size_t b = 1; b < f.size() && pairs.size() < c.max_pairs; ++b) {
    const double dt = f[b].t_s - f[a].t_s;
    if (dt < gap) continue;
    if (dt <= 2.0 * gap) pairs.emplace_back(a, b);
    a = b;
  }
  return pairs;
}

PairCheck check_pair(const PlacedFrame& a, const PlacedFrame& b, const LidarMotionConfig& c) {
  PairCheck check;
  check.t0_s = a.t_s;
  check.t1_s = b.t_s;
  const Iso3 T_a_b_ins = a.T_world_lidar.inverse() * b.T_world_lidar;
  const ScanRegistrationResult reg = register_scans(voxel_centroids(a.p_lidar, c.target_voxel_m),
                                                    voxel_centroids(b.p_lidar, c.source_voxel_m), T_a_b_ins, c.icp);
  if (!reg.converged || reg.inlier_ratio < c.min_inlier_ratio) return check;
  check.used = true;
  check.jump_m = a.T_world_lidar.linear() * (T_a_b_ins.translation() - reg.T_target_source.translation());
  check.turn_deg = std::abs(Eigen::AngleAxisd(T_a_b_ins.linear()).angle() -
                            Eigen::AngleAxisd(reg.T_target_source.linear()).angle()) * kDegPerRad;
  // Rotations that disagree (a clock offset in a turn: 20 deg/s x 35 ms = 0.7 deg; a poor
  // registration) make the translation say nothing about the INS position.
  check.used = check.turn_deg <= c.min_turn_deg;
  return check;
}

double jump_threshold(const std::vector<PairCheck>& pairs, const LidarMotionConfig& c) {
  std::vector<double> norms;
  for (const PairCheck& p : pairs)
    if (p.used) norms.push_back(p.jump_m.norm());
  return norms.empty() ? c.min_jump_m : std::max(c.min_jump_m, c.jump_factor * median(norms));
}

// A jump and its return (opposite discrepancies) bound a bad stretch; an edge without a return
// leaves out its own pair (which side is wrong is the map residual's to say).
std::vector<TimeSpan> motion_spans(const std::vector<PairCheck>& pairs, double period_s, const LidarMotionConfig& c) {
  std::vector<std::size_t> edges;
  for (std::size_t i = 0; i < pairs.size(); ++i)
    if (pairs[i].flagged) edges.push_back(i);
  std::vector<char> done(edges.size(), 0);
  std::vector<TimeSpan> spans;
  for (std::size_t e = 0; e < edges.size(); ++e) {
    if (done[e]) continue;
    const PairCheck& p = pairs[edges[e]];
    for (std::size_t k = e + 1; k < edges.size() && !done[e]; ++k) {
      const PairCheck& q = pairs[edges[k]];
      if (done[k] || q.t1_s - p.t0_s > c.max_span_s) continue;
      if ((p.jump_m + q.jump_m).norm() > 0.5 * std::max(p.jump_m.norm(), q.jump_m.norm())) continue;
      done[e] = done[k] = 1;
      spans.push_back({p.t0_s + kEps_s, q.t1_s - kPeriodSlack * period_s - kEps_s,
                       fmt::format("the LiDAR motion shows the INS position jump by {:.2f} m and back {:.1f} s later",
                                   p.jump_m.norm(), q.t0_s - p.t0_s),
                       SpanKind::kMotionMismatch, SpanSource::kLidarMotion});
    }
    if (done[e]) continue;
    spans.push_back({p.t0_s - kPeriodSlack * period_s, p.t1_s,
                     fmt::format("the LiDAR and INS motions between these frames differ by {:.2f} m, {:.2f} deg",
                                 p.jump_m.norm(), p.turn_deg),
                     SpanKind::kMotionMismatch, SpanSource::kLidarMotion});
  }
  return spans;
}

// ---- Map residual -----------------------------------------------------------------------------

struct Moments {
  double n = 0.0;
  Vec3 sum = Vec3::Zero();
  Mat3 outer = Mat3::Zero();
  void add(const Vec3& p) {
    n += 1.0;
    sum += p;
    outer += p * p.transpose();
  }
  void remove(const Moments& o) {
    n -= o.n;
    sum -= o.sum;
    outer -= o.outer;
  }
};

// Per voxel, its points' moments in total and per time block, so that the map of "every frame
// but those near time t" is the total minus a few blocks.
struct MapVoxel {
  Moments total;
  std::vector<std::pair<int, Moments>> blocks;
};

struct TimeBlocks {
  double t0_s = 0.0, block_s = 1.0;
  int of(double t_s) const { return static_cast<int>(std::floor((t_s - t0_s) / block_s)); }
};

struct VoxelPlane {
  bool ok = false;
  Vec3 centre = Vec3::Zero(), normal = Vec3::UnitZ();
};

using MapGrid = VoxelKeyMap<MapVoxel>;

MapGrid build_map(const std::vector<PlacedFrame>& frames, const TimeBlocks& blocks, double voxel_m) {
  MapGrid grid;
  for (const PlacedFrame& f : frames) {
    const int b = blocks.of(f.t_s);
    for (const Vec3& p_lidar : f.p_lidar) {
      const Vec3 p = f.T_world_lidar * p_lidar;
      MapVoxel& v = grid[voxel_key(p, 1.0 / voxel_m)];
      v.total.add(p);
      if (v.blocks.empty() || v.blocks.back().first != b) v.blocks.push_back({b, Moments{}});
      v.blocks.back().second.add(p);
    }
  }
  return grid;
}

VoxelPlane allowed_plane(const MapVoxel& v, int block_lo, int block_hi, const MapResidualConfig& c) {
  Moments m = v.total;
  for (const auto& [b, mb] : v.blocks)
    if (b >= block_lo && b <= block_hi) m.remove(mb);
  if (m.n < static_cast<double>(c.min_plane_points)) return {};
  const Vec3 mean = m.sum / m.n;
  const Mat3 cov = m.outer / m.n - mean * mean.transpose();
  const Eigen::SelfAdjointEigenSolver<Mat3> eig(cov);
  const Vec3 lambda = eig.eigenvalues().cwiseMax(0.0);
  if (std::sqrt(lambda(0)) > c.max_plane_thickness_m || lambda(1) < 0.04) return {};  // thick, or a line
  return {true, mean, eig.eigenvectors().col(0)};
}

struct Alignment {
  bool ok = false;
  Vec3 delta_m = Vec3::Zero();  // moves the frame onto the map
  Mat3 information = Mat3::Zero();
};

Alignment align_to_map(const PlacedFrame& f, const MapGrid& grid, const TimeBlocks& blocks,
                       const MapResidualConfig& c) {
  const int lo = blocks.of(f.t_s - c.min_time_apart_s), hi = blocks.of(f.t_s + c.min_time_apart_s);
  // The planes this frame meets, each fitted once: slot[key] is its index in `planes` plus one.
  VoxelKeyMap<std::uint32_t> slot;
  std::vector<VoxelPlane> planes;
  const auto plane_at = [&](std::uint64_t key) -> std::uint32_t {
    std::uint32_t& k = slot[key];
    if (k == 0) {
      const MapVoxel* v = grid.find(key);
      planes.push_back(v ? allowed_plane(*v, lo, hi, c) : VoxelPlane{});
      k = static_cast<std::uint32_t>(planes.size());
    }
    return k - 1;
  };
  Alignment a;
  const int iterations = std::max(c.iterations, 2);
  const double shrink = std::pow(c.gate_end_m / c.gate_start_m, 1.0 / (iterations - 1));
  double gate = c.gate_start_m;
  std::vector<Vec3> p_world(f.p_lidar.size());
  for (std::size_t i = 0; i < p_world.size(); ++i) p_world[i] = f.T_world_lidar * f.p_lidar[i];
  // Each point's voxel and plane of the last iteration: the small steps rarely change them.
  std::vector<std::uint64_t> last_key(p_world.size(), std::numeric_limits<std::uint64_t>::max());
  std::vector<std::uint32_t> last_plane(p_world.size(), 0);
  for (int it = 0; it < iterations; ++it, gate *= shrink) {
    Mat3 H = Mat3::Zero();
    Vec3 g = Vec3::Zero();
    for (std::size_t i = 0; i < p_world.size(); ++i) {
      const Vec3 p = p_world[i] + a.delta_m;
      const std::uint64_t key = voxel_key(p, 1.0 / c.voxel_m);
      if (key != last_key[i]) last_key[i] = key, last_plane[i] = plane_at(key);
      const VoxelPlane& plane = planes[last_plane[i]];
      if (!plane.ok) continue;
      const double r = plane.normal.dot(p - plane.centre);
      if (std::abs(r) > gate) continue;
      const double w = std::abs(r) <= c.huber_m ? 1.0 : c.huber_m / std::abs(r);
      H += w * plane.normal * plane.normal.transpose();
      g += w * r * plane.normal;
    }
    if (H.trace() < c.min_information) return {};
    a.delta_m -= (H + 1e-3 * H.trace() * Mat3::Identity()).ldlt().solve(g);
    a.information = H;
  }
  a.ok = true;
  return a;
}

// Projector onto the directions the information measures.
Mat3 measured_directions(const Mat3& information, double min_information) {
  const Eigen::SelfAdjointEigenSolver<Mat3> eig(information);
  Mat3 P = Mat3::Zero();
  for (int i = 0; i < 3; ++i)
    if (eig.eigenvalues()(i) >= min_information) P += eig.eigenvectors().col(i) * eig.eigenvectors().col(i).transpose();
  return P;
}

// The drive-wide part of the offsets: a constant plus velocity x a time offset (stage 1 does not
// estimate the offset; at 10 m/s each 10 ms of it moves every frame 10 cm along its travel).
// Robust least squares over the frames' measured directions.
Eigen::Vector4d drive_wide_offset(const std::vector<FrameOffset>& offsets, const std::vector<Mat3>& P,
                                  const std::vector<Vec3>& velocity, double huber_m) {
  Eigen::Vector4d x = Eigen::Vector4d::Zero();
  for (int round = 0; round < 4; ++round) {
    Eigen::Matrix4d A = Eigen::Matrix4d::Identity() * 1e-6;
    A(3, 3) = 1.0;  // a weak prior keeps the time offset at 0 when the speed never changes direction
    Eigen::Vector4d b = Eigen::Vector4d::Zero();
    for (std::size_t k = 0; k < offsets.size(); ++k) {
      if (!offsets[k].used) continue;
      Eigen::Matrix<double, 3, 4> J;
      J << Mat3::Identity(), velocity[k];
      const Vec3 r = P[k] * (offsets[k].offset_m - J * x);
      const double w = round == 0 || r.norm() <= huber_m ? 1.0 : huber_m / r.norm();
      A += w * J.transpose() * P[k] * J;
      b += w * J.transpose() * P[k] * offsets[k].offset_m;
    }
    x = A.ldlt().solve(b);
  }
  return x;
}

// Runs of flagged frames, each bounded by the nearest good frames around it (what lies between a
// good and a bad frame is unknown, so it is left out too). A lone frame needs twice the threshold.
std::vector<TimeSpan> offset_spans(const std::vector<FrameOffset>& offsets, double threshold_m, double period_s) {
  std::vector<TimeSpan> spans;
  std::size_t i = 0;
  while (i < offsets.size()) {
    if (!offsets[i].used || !offsets[i].flagged) {
      ++i;
      continue;
    }
    std::size_t j = i, count = 0;
    double worst = 0.0;
    while (j < offsets.size() && (!offsets[j].used || offsets[j].flagged)) {
      if (offsets[j].used) ++count, worst = std::max(worst, offsets[j].residual_m);
      ++j;
    }
    if (count >= 2 || worst > 2.0 * threshold_m) {
      const double begin = i > 0 ? offsets[i - 1].t_s + kEps_s : offsets[i].t_s - kPeriodSlack * period_s;
      const double end = j < offsets.size() ? offsets[j].t_s - kPeriodSlack * period_s - kEps_s : offsets[j - 1].t_s;
      spans.push_back({begin, std::max(end, begin),
                       fmt::format("{} frames sit up to {:.2f} m off the map of the rest of the drive", count, worst),
                       SpanKind::kOffMap, SpanSource::kMapResidual});
    }
    i = j;
  }
  return spans;
}

void map_residual_check(const std::vector<PlacedFrame>& frames, const MapResidualConfig& c, double period_s,
                        InsScreenResult& out) {
  if (frames.size() < 3) return;
  const TimeBlocks blocks{frames.front().t_s, 0.5 * c.min_time_apart_s};
  const MapGrid grid = build_map(frames, blocks, c.voxel_m);
  std::vector<Alignment> aligned(frames.size());
  tbb::parallel_for(std::size_t{0}, frames.size(),
                    [&](std::size_t k) { aligned[k] = align_to_map(frames[k], grid, blocks, c); });
  out.offsets.resize(frames.size());
  std::vector<Mat3> P(frames.size(), Mat3::Zero());
  std::vector<Vec3> velocity(frames.size());
  for (std::size_t k = 0; k < frames.size(); ++k) {
    out.offsets[k].t_s = frames[k].t_s;
    out.offsets[k].used = aligned[k].ok;
    out.offsets[k].offset_m = -aligned[k].delta_m;
    if (aligned[k].ok) P[k] = measured_directions(aligned[k].information, c.min_information);
    velocity[k] = frames[k].velocity_mps;
  }
  const Eigen::Vector4d wide = drive_wide_offset(out.offsets, P, velocity, c.huber_m);
  out.time_offset_s = wide(3);
  std::vector<double> residuals;
  for (std::size_t k = 0; k < frames.size(); ++k) {
    FrameOffset& o = out.offsets[k];
    if (!o.used) continue;
    o.residual_m = (P[k] * (o.offset_m - wide.head<3>() - velocity[k] * wide(3))).norm();
    residuals.push_back(o.residual_m);
  }
  out.offset_threshold_m = std::max(c.min_offset_m, c.offset_factor * median(residuals));
  for (FrameOffset& o : out.offsets) o.flagged = o.used && o.residual_m > out.offset_threshold_m;
  const std::vector<TimeSpan> spans = offset_spans(out.offsets, out.offset_threshold_m, period_s);
  out.spans.insert(out.spans.end(), spans.begin(), spans.end());
}

void motion_check(const std::vector<PlacedFrame>& frames, const LidarMotionConfig& c, double period_s,
                  InsScreenResult& out) {
  const auto pairs = chain_pairs(frames, c);
  out.pairs.resize(pairs.size());
  tbb::parallel_for(std::size_t{0}, pairs.size(), [&](std::size_t k) {
    out.pairs[k] = check_pair(frames[pairs[k].first], frames[pairs[k].second], c);
  });
  out.jump_threshold_m = jump_threshold(out.pairs, c);
  for (PairCheck& p : out.pairs)
    p.flagged = p.used && p.jump_m.norm() > out.jump_threshold_m;
  const std::vector<TimeSpan> spans = motion_spans(out.pairs, period_s, c);
  out.spans.insert(out.spans.end(), spans.begin(), spans.end());
}

}  // namespace

std::vector<TimeSpan> status_spans(const std::vector<InsQuality>& quality, const InsStatusConfig& config,
                                   double* typical_stddev_m) {
  const StatusTypical typical = typical_status(quality);
  if (typical_stddev_m) *typical_stddev_m = typical.stddev_m;
  const double limit = std::isfinite(typical.stddev_m)
                           ? std::max(config.min_stddev_m, config.stddev_factor * typical.stddev_m)
                           : config.min_stddev_m;
  std::vector<TimeSpan> spans;
  std::size_t i = 0;
  while (i < quality.size()) {
    const std::optional<SpanKind> kind = status_kind(quality[i], typical, limit);
    if (!kind) {
      ++i;
      continue;
    }
    std::size_t j = i;
    while (j + 1 < quality.size() && status_kind(quality[j + 1], typical, limit) == kind) ++j;
    // What lies between the last good sample and the first bad one is unknown: left out too.
    const double begin = (i > 0 ? quality[i - 1].t_s : quality[i].t_s) - config.margin_s;
    const double end = (j + 1 < quality.size() ? quality[j + 1].t_s : quality[j].t_s) + config.margin_s;
    spans.push_back({begin, end, status_reason(quality, i, j, typical), *kind, SpanSource::kInsStatus});
    i = j + 1;
  }
  return spans;
}

InsScreenResult screen_with_lidar(const FrameStore& store, const std::vector<std::size_t>& frames,
                                  const Iso3& T_ins_lidar, double time_offset_s, const InsScreenConfig& config) {
  const auto start = std::chrono::steady_clock::now();
  InsScreenResult out;
  SweepFilter filter = config.filter;
  filter.min_range_m = std::max(filter.min_range_m, store.base_filter().min_range_m);
  std::vector<std::size_t> sorted = frames;
  std::sort(sorted.begin(), sorted.end());
  sorted.erase(std::unique(sorted.begin(), sorted.end()), sorted.end());
  const std::vector<PlacedFrame> placed = place_frames(store, sorted, T_ins_lidar, time_offset_s, filter);
  // Independent checks side by side: the map's build is serial, the registrations fill the other core.
  InsScreenResult by_map;
  tbb::parallel_invoke([&] { motion_check(placed, config.motion, store.sweep_period_s(), out); },
                       [&] { map_residual_check(placed, config.map, store.sweep_period_s(), by_map); });
  out.offsets = std::move(by_map.offsets);
  out.time_offset_s = by_map.time_offset_s;
  out.offset_threshold_m = by_map.offset_threshold_m;
  out.spans.insert(out.spans.end(), by_map.spans.begin(), by_map.spans.end());
  out.wall_time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return out;
}

InsScreenResult screen_with_status(const std::vector<InsQuality>& quality, const InsScreenConfig& config) {
  InsScreenResult out;
  if (config.from_status && !quality.empty()) out.spans = status_spans(quality, config.status, &out.typical_stddev_m);
  return out;
}

InsScreenResult lidar_checks(const FrameStore& store, const Iso3& T_ins_lidar, double time_offset_s,
                             const InsScreenConfig& config) {
  if (!config.from_lidar) return {};
  return screen_with_lidar(store, check_sample(store, config.max_frames, time_offset_s), T_ins_lidar, time_offset_s,
                           config);
}

InsScreenResult with_lidar_checks(const InsScreenResult& status, InsScreenResult lidar) {
  lidar.typical_stddev_m = status.typical_stddev_m;
  std::vector<TimeSpan> spans = status.spans;
  spans.insert(spans.end(), lidar.spans.begin(), lidar.spans.end());
  lidar.spans = std::move(spans);
  return lidar;
}

FrameStore leave_out_spans(const FrameStore& store, const std::vector<TimeSpan>& spans) {
  if (spans.empty()) return store;
  std::vector<TimeSpan> excluded = store.excluded();
  excluded.insert(excluded.end(), spans.begin(), spans.end());
  return store.with(store.poses(), std::move(excluded));
}

FrameStore leave_out_status_spans(const FrameStore& store, const InsScreenConfig& config, InsScreenResult& out) {
  const InsScreenResult status = screen_with_status(store.data().ins_quality, config);
  if (std::isfinite(status.typical_stddev_m)) out.typical_stddev_m = status.typical_stddev_m;
  out.spans.insert(out.spans.end(), status.spans.begin(), status.spans.end());
  return leave_out_spans(store, status.spans);
}

double spans_duration_s(std::vector<TimeSpan> spans) {
  std::sort(spans.begin(), spans.end(), [](const TimeSpan& a, const TimeSpan& b) { return a.begin_s < b.begin_s; });
  double total = 0.0, covered_to = -std::numeric_limits<double>::infinity();
  for (const TimeSpan& s : spans) {
    const double from = std::max(s.begin_s, covered_to);
    if (s.end_s > from) total += s.end_s - from;
    covered_to = std::max(covered_to, s.end_s);
  }
  return total;
}

}  // namespace insalign
