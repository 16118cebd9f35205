#include "input/clock_alignment.hpp"

#include <fmt/format.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>

#include "core/errors.hpp"
#include "core/frames.hpp"
#include "core/scan_registration.hpp"
#include "core/voxel_grid.hpp"
#include "input/bag_dataset.hpp"

namespace insalign::io {
namespace {

constexpr double kEndsAgree_s = 2.0;        // as the recordings' check: ends this close are the same span
constexpr double kRangeGapTolerance_s = 0.15;  // whole-second match of the gap between the ranges' middles
constexpr std::size_t kMinPairs = 3;        // pairs a candidate needs to be judged
constexpr double kMinTurnDeg = 2.0;         // a pair that turns at least this tells offsets apart
constexpr std::size_t kListed = 5;          // candidates named in the evidence line

struct PotentialPair {
  std::size_t a = 0, next = 0, b = 0;  // frame indices: the pair (a, b) and a's successor (ICP start)
  double t_a_s = 0.0, t_b_s = 0.0;     // mid-sweep times, LiDAR clock
  std::vector<double> ins_deg;         // per candidate, NaN outside the INS range
};

double angle_deg(const Mat3& R) { return Eigen::AngleAxisd(R).angle() * kDegPerRad; }

std::string agree_meaning() { return "the clocks agree"; }

// 0 and every known whole-second offset, both signs, with the recordings' words for each.
std::vector<std::pair<double, std::string>> known_offsets() {
  constexpr double kGpsEpoch = 315964800.0;
  std::vector<double> whole = {18.0, 19.0, 37.0, kGpsEpoch, kGpsEpoch + 18.0};
  for (int quarters = 1; quarters <= 56; ++quarters) {
    whole.insert(whole.end(), {900.0 * quarters, 900.0 * quarters + 18.0, 900.0 * quarters - 18.0});
  }
  std::vector<std::pair<double, std::string>> out = {{0.0, agree_meaning()}};
  for (const double w : whole) {
    for (const double d : {w, -w}) {
      const auto e = explain_clock_gap(d, 1e-6);
      out.emplace_back(d, e ? e->meaning : fmt::format("a whole number of seconds ({:.0f} s)", d));
    }
  }
  return out;
}

double inside_fraction(const FrameSource& frames, const PoseStream& poses, double offset_s) {
  std::size_t inside = 0;
  for (const FrameInfo& f : frames.frames) inside += poses.covers(f.t_end_s + offset_s) ? 1 : 0;
  return static_cast<double>(inside) / static_cast<double>(std::max<std::size_t>(1, frames.frames.size()));
}

ClockAlignment ranges_of(const FrameSource& frames, const PoseStream& poses) {
  ClockAlignment a;
  a.lidar_begin_s = frames.frames.front().t_end_s, a.lidar_end_s = frames.frames.back().t_end_s;
  a.ins_begin_s = poses.t_begin(), a.ins_end_s = poses.t_end();
  a.inside_fraction = inside_fraction(frames, poses, 0.0);
  return a;
}

bool ends_agree(const ClockAlignment& a) {
  return std::abs(a.ins_begin_s - a.lidar_begin_s) <= kEndsAgree_s && std::abs(a.ins_end_s - a.lidar_end_s) <= kEndsAgree_s;
}

std::string signed_s(double s) { return fmt::format("{:.3f} s {}", std::abs(s), s >= 0 ? "later" : "earlier"); }

// The ranges in the recordings' words (bag_dataset.cpp's clock summary).
std::string range_words(const ClockAlignment& a, double inside) {
  if (a.lidar_end_s < a.ins_begin_s) {
    return fmt::format("the LiDAR frames end {:.3f} s before the INS records begin", a.ins_begin_s - a.lidar_end_s);
  }
  if (a.lidar_begin_s > a.ins_end_s) {
    return fmt::format("the LiDAR frames begin {:.3f} s after the INS records end", a.lidar_begin_s - a.ins_end_s);
  }
  return fmt::format("{:.0f}% of the LiDAR frames lie inside the INS time range", 100.0 * inside);
}

double middle_gap_s(const ClockAlignment& a) {
  return 0.5 * (a.ins_begin_s + a.ins_end_s - a.lidar_begin_s - a.lidar_end_s);
}

std::string gap_words(double gap_s) {
  std::string out = fmt::format("the INS stamps are {} than the LiDAR's (between the middles of the two ranges)", signed_s(gap_s));
  if (const auto e = explain_clock_gap(gap_s, kRangeGapTolerance_s)) {
    return out + fmt::format(", close to {:.0f} s: {}", e->whole_s, e->meaning);
  }
  const double whole = std::round(gap_s);
  if (whole != 0.0 && std::abs(gap_s - whole) < kRangeGapTolerance_s) {
    return out + fmt::format(", a whole number of seconds ({:.0f} s) of no known kind", whole);
  }
  return out + ", not a whole number of seconds";
}

std::string ranges_line(const ClockAlignment& a) {
  return fmt::format("LiDAR frames {:.3f} .. {:.3f} s, INS {:.3f} .. {:.3f} s: {}", a.lidar_begin_s, a.lidar_end_s,
                     a.ins_begin_s, a.ins_end_s, range_words(a, a.inside_fraction));
}

[[noreturn]] void throw_gap(const ClockAlignment& a, const std::string& file, const std::string& why) {
  const double inside = a.inside_fraction;
  ClockReport c;
  c.lidar_begin_s = a.lidar_begin_s, c.lidar_end_s = a.lidar_end_s, c.ins_begin_s = a.ins_begin_s, c.ins_end_s = a.ins_end_s;
  c.frames_inside_fraction = inside;
  c.explanation = explain_clock_gap(middle_gap_s(a), kRangeGapTolerance_s);
  c.consistent = false;
  c.summary = ranges_line(a) + "; " + gap_words(middle_gap_s(a));
  const std::string lead = inside == 0.0
                               ? fmt::format("no frame lies within the INS time range [{:.3f}, {:.3f}] s (frames span "
                                             "[{:.3f}, {:.3f}] s): ",
                                             a.ins_begin_s, a.ins_end_s, a.lidar_begin_s, a.lidar_end_s)
                               : "";
  throw ClockGapError(file, lead + "the LiDAR and INS clocks disagree: " + c.summary + (why.empty() ? "" : "; " + why) +
                                ". Fix the clock of one sensor, or give the offset (input.clock_offset_s: t_ins = "
                                "t_lidar + offset), and run again", c);
}

std::vector<ClockCandidate> fitting_candidates(const FrameSource& frames, const PoseStream& poses, double min_inside) {
  std::vector<ClockCandidate> out;
  for (const auto& [offset, meaning] : known_offsets()) {
    const double inside = inside_fraction(frames, poses, offset);
    if (inside >= min_inside) out.push_back({offset, meaning, inside});
  }
  return out;
}


// Every frame with a successor and a partner pair_gap_s later (no hole in between), with the INS
// rotation angle between the two mid-sweep times at each candidate offset.
std::vector<PotentialPair> potential_pairs(const FrameSource& frames, const PoseStream& poses,
                                           const std::vector<ClockCandidate>& candidates, double gap_s) {
  const std::vector<FrameInfo>& f = frames.frames;
  const double half_period_s = 0.5 * sweep_period_s(f);
  std::vector<PotentialPair> out;
  std::size_t b = 0;
  for (std::size_t a = 0; a + 1 < f.size(); ++a) {
    b = std::max(b, a + 2);
    while (b < f.size() && f[b].t_end_s - f[a].t_end_s < gap_s - half_period_s) ++b;
    if (b >= f.size()) break;
    const double dt = f[b].t_end_s - f[a].t_end_s;
    if (dt > 1.5 * gap_s || f[a + 1].t_end_s - f[a].t_end_s > 3.0 * half_period_s) continue;  // a hole
    PotentialPair p{a, a + 1, b, f[a].t_end_s - half_period_s, f[b].t_end_s - half_period_s, {}};
    for (const ClockCandidate& c : candidates) {
      p.ins_deg.push_back(rotation_angle_deg(poses, p.t_a_s + c.offset_s, p.t_b_s + c.offset_s));
    }
    out.push_back(std::move(p));
  }
  return out;
}

// How much a pair tells the candidates apart: the spread of their INS angles (one candidate: its turn).
double pair_score(const PotentialPair& p) {
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (const double d : p.ins_deg) {
    if (std::isfinite(d)) lo = std::min(lo, d), hi = std::max(hi, d);
  }
  if (!std::isfinite(lo)) return -1.0;
  return hi > lo ? hi - lo : hi;
}

// The most telling pairs, never overlapping in time; then enough pairs for every candidate.
std::vector<std::size_t> select_pairs(const std::vector<PotentialPair>& pairs, std::size_t candidates, std::size_t wanted,
                                      double gap_s) {
  std::vector<std::size_t> chosen;
  const auto free = [&](std::size_t i) {
    return std::none_of(chosen.begin(), chosen.end(),
                        [&](std::size_t j) { return std::abs(pairs[i].t_a_s - pairs[j].t_a_s) < gap_s; });
  };
  const auto take_by = [&](auto score, std::size_t until) {
    std::vector<std::size_t> order(pairs.size());
    for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
    std::stable_sort(order.begin(), order.end(), [&](std::size_t x, std::size_t y) { return score(x) > score(y); });
    for (const std::size_t i : order) {
      if (until == 0 || score(i) < 0.0) break;
      if (free(i)) chosen.push_back(i), --until;
    }
  };
  take_by([&](std::size_t i) { return pair_score(pairs[i]); }, wanted);
  for (std::size_t c = 0; c < candidates; ++c) {
    const std::size_t have = static_cast<std::size_t>(std::count_if(
        chosen.begin(), chosen.end(), [&](std::size_t i) { return std::isfinite(pairs[i].ins_deg[c]); }));
    if (have < kMinPairs) {
      take_by([&](std::size_t i) { return std::isfinite(pairs[i].ins_deg[c]) ? pairs[i].ins_deg[c] : -1.0; }, kMinPairs - have);
    }
  }
  return chosen;
}

std::vector<Vec3> centroids(const FrameSource& frames, std::size_t i, const ClockCheckConfig& config, double voxel_m) {
  const Sweep s = thin_sweep(frames.load(i), SweepFilter{.min_range_m = config.body_radius_m, .max_range_m = 80.0});
  std::vector<Vec3> p(s.p_lidar.size());
  for (std::size_t k = 0; k < p.size(); ++k) p[k] = s.p_lidar[k].cast<double>();
  return voxel_centroids(p, voxel_m);
}

// The LiDAR's rotation angle from sweep a to sweep b: a to its successor from identity first, that
// motion repeated as the start for b (scan registration needs a start within a metre or so).
double lidar_angle_deg(const FrameSource& frames, const PotentialPair& p, const ClockCheckConfig& config) {
  try {
    const std::vector<Vec3> target = centroids(frames, p.a, config, config.target_voxel_m);
    const ScanRegistrationResult step =
        register_scans(target, centroids(frames, p.next, config, config.source_voxel_m), Iso3::Identity());
    if (!step.converged) return std::numeric_limits<double>::quiet_NaN();
    Iso3 T_start = Iso3::Identity();
    for (std::size_t k = p.a; k < p.b; ++k) T_start = T_start * step.T_target_source;
    const ScanRegistrationResult reg =
        register_scans(target, centroids(frames, p.b, config, config.source_voxel_m), T_start);
    return reg.converged ? angle_deg(reg.T_target_source.linear()) : std::numeric_limits<double>::quiet_NaN();
  } catch (const InputError&) {  // an unreadable sweep: the pair says nothing
    return std::numeric_limits<double>::quiet_NaN();
  }
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 == 1 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

// Registers the chosen pairs (in parallel) and scores every candidate by its median difference.
void compare_by_data(const FrameSource& frames, const PoseStream& poses, const ClockCheckConfig& config,
                     ClockAlignment& a) {
  const std::vector<PotentialPair> all = potential_pairs(frames, poses, a.candidates, config.pair_gap_s);
  const std::vector<std::size_t> chosen = select_pairs(all, a.candidates.size(), config.pairs, config.pair_gap_s);
  std::vector<double> lidar(chosen.size());
  tbb::parallel_for(std::size_t{0}, chosen.size(), [&](std::size_t k) { lidar[k] = lidar_angle_deg(frames, all[chosen[k]], config); });
  a.checked_by_data = true;
  for (std::size_t k = 0; k < chosen.size(); ++k) {
    if (!std::isfinite(lidar[k])) continue;
    const PotentialPair& p = all[chosen[k]];
    a.pairs.push_back({frames.frames[p.a].name, frames.frames[p.b].name, p.t_a_s, p.t_b_s, lidar[k], p.ins_deg});
  }
  std::sort(a.pairs.begin(), a.pairs.end(), [](const ClockPair& x, const ClockPair& y) { return x.t_a_s < y.t_a_s; });
  for (std::size_t c = 0; c < a.candidates.size(); ++c) {
    std::vector<double> diffs;
    for (const ClockPair& p : a.pairs) {
      if (std::isfinite(p.ins_deg[c])) diffs.push_back(std::abs(p.lidar_deg - p.ins_deg[c]));
    }
    a.candidates[c].pairs = diffs.size();
    if (diffs.size() >= kMinPairs) a.candidates[c].median_diff_deg = median(diffs);
  }
}

// Candidates by their median difference, the judged ones first.
std::vector<std::size_t> ranked(const std::vector<ClockCandidate>& c) {
  std::vector<std::size_t> order(c.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  const auto key = [&](std::size_t i) {
    return std::isfinite(c[i].median_diff_deg) ? c[i].median_diff_deg : std::numeric_limits<double>::infinity();
  };
  std::stable_sort(order.begin(), order.end(), [&](std::size_t x, std::size_t y) { return key(x) < key(y); });
  return order;
}

std::string evidence_line(const ClockAlignment& a) {
  if (a.pairs.empty()) return "no LiDAR frame pair could be registered to compare rotations";
  const std::vector<std::size_t> order = ranked(a.candidates);
  std::string listed;
  for (std::size_t k = 0; k < std::min(order.size(), kListed); ++k) {
    const ClockCandidate& c = a.candidates[order[k]];
    listed += fmt::format("{}{:+.0f} s: {}", k ? ", " : "", c.offset_s,
                          std::isfinite(c.median_diff_deg) ? fmt::format("{:.3f} deg", c.median_diff_deg) : "not judged");
  }
  return fmt::format("LiDAR rotation angles over {} frame pairs ({:.1f} s apart) against the INS's at each candidate "
                     "offset (median |difference|): {}{}",
                     a.pairs.size(), a.pairs.front().t_b_s - a.pairs.front().t_a_s, listed,
                     order.size() > kListed ? fmt::format(" (and {} more)", order.size() - kListed) : "");
}

// Whether the best candidate is the clear winner: it matches, turns enough to say so, and every
// other candidate is ruled out.
bool clear_winner(const ClockAlignment& a, std::size_t best, const ClockCheckConfig& config) {
  const double m = a.candidates[best].median_diff_deg;
  if (!(m <= config.max_match_deg)) return false;
  const std::size_t turns = static_cast<std::size_t>(std::count_if(a.pairs.begin(), a.pairs.end(), [&](const ClockPair& p) {
    return std::isfinite(p.ins_deg[best]) && p.ins_deg[best] >= kMinTurnDeg;
  }));
  if (turns < kMinPairs) return false;
  for (std::size_t c = 0; c < a.candidates.size(); ++c) {
    if (c == best) continue;
    const double other = a.candidates[c].median_diff_deg;
    if (!(other >= std::max(config.min_ratio * m, config.max_match_deg))) return false;
  }
  return true;
}

std::string decision_words(const ClockCandidate& c) {
  if (c.offset_s == 0.0) return agree_meaning();
  return fmt::format("the INS clock is {:g} s {} the LiDAR's: {}; corrected (INS times shifted by {:+g} s)",
                     std::abs(c.offset_s), c.offset_s > 0 ? "ahead of" : "behind", c.meaning, -c.offset_s);
}

void take(ClockAlignment& a, const ClockCandidate& c, const std::string& how) {
  a.offset_s = c.offset_s;
  a.meaning = c.meaning;
  a.decision = decision_words(c) + (how.empty() ? "" : " (" + how + ")");
  a.summary = ranges_line(a) + "; " + a.decision;
}

std::size_t index_of_zero(const std::vector<ClockCandidate>& c) {
  for (std::size_t i = 0; i < c.size(); ++i) {
    if (c[i].offset_s == 0.0) return i;
  }
  return c.size();
}

}  // namespace

PoseStream shifted_poses(const PoseStream& poses, double shift_s) {
  std::vector<StampedPose> p = poses.poses();
  for (StampedPose& s : p) s.t_s += shift_s;
  return PoseStream(std::move(p));
}

std::string describe_offset(double offset_s, const std::string& meaning) {
  return offset_s == 0.0 ? "0 s (" + meaning + ")" : fmt::format("{:+.0f} s ({})", offset_s, meaning);
}

ClockAlignment align_clocks(const FrameSource& frames, const PoseStream& poses, const ClockCheckConfig& config,
                            const std::string& file) {
  ClockAlignment a = ranges_of(frames, poses);
  a.candidates = fitting_candidates(frames, poses, config.min_inside_fraction);
  if (a.candidates.empty()) throw_gap(a, file, "no known offset keeps the frames inside the INS range");
  const std::size_t zero = index_of_zero(a.candidates);
  const bool zero_fits = zero < a.candidates.size();
  if (zero_fits && a.candidates.size() == 1) {
    take(a, a.candidates[zero], "no other known offset keeps the frames inside the INS range");
    return a;
  }
  if (zero_fits && ends_agree(a)) {
    take(a, a.candidates[zero], "both ends of the ranges agree within 2 s");
    return a;
  }
  if (!config.enabled) {
    if (!zero_fits) throw_gap(a, file, "the data check is off (input.clock.enabled)");
    take(a, a.candidates[zero], "not checked: input.clock.enabled is false");
    return a;
  }
  compare_by_data(frames, poses, config, a);
  a.evidence = evidence_line(a);
  const std::size_t best = ranked(a.candidates).front();
  if (clear_winner(a, best, config)) {
    take(a, a.candidates[best], "decided by the LiDAR motion");
    return a;
  }
  const double zero_median = zero_fits ? a.candidates[zero].median_diff_deg : 0.0;
  if (zero_fits && !(zero_median > config.max_match_deg)) {
    take(a, a.candidates[zero], "the LiDAR motion cannot tell the candidates apart");
    a.warnings.push_back("clock check: the LiDAR motion cannot tell the candidate clock offsets apart (" + a.evidence +
                         "); assuming the clocks agree. Drive turns, or give input.clock_offset_s");
    return a;
  }
  throw_gap(a, file,
            "no candidate offset is clearly confirmed by the data: " + a.evidence +
                " (a LiDAR stamped by its host adds tenths of a second to a whole-second offset: give the whole seconds "
                "as input.clock_offset_s and the start measures the rest within +-1 s)");
}

ClockAlignment given_clock_offset(const FrameSource& frames, const PoseStream& poses, double offset_s,
                                  const std::string& file) {
  ClockAlignment a = ranges_of(frames, poses);
  const ClockCandidate given{offset_s, "given by input.clock_offset_s", inside_fraction(frames, poses, offset_s)};
  if (given.inside_fraction == 0.0) throw_gap(a, file, fmt::format("the given offset {:+.3f} s leaves no frame inside", offset_s));
  a.candidates = {given};
  take(a, given, "not checked");
  return a;
}

ClockAlignment confirm_clock_correction(const FrameSource& frames, const PoseStream& corrected_poses, double applied_s,
                                        const std::string& meaning, const ClockCheckConfig& config,
                                        const std::string& file) {
  // Offsets of the recorded INS clock, as align_clocks states them: `applied_s` is the correction.
  const PoseStream recorded = shifted_poses(corrected_poses, applied_s);
  ClockAlignment a = ranges_of(frames, recorded);
  for (const auto& [offset, what] : std::vector<std::pair<double, std::string>>{{applied_s, meaning}, {0.0, agree_meaning()}}) {
    const double inside = inside_fraction(frames, recorded, offset);
    if (inside > 0.0) a.candidates.push_back({offset, what, inside});
  }
  if (a.candidates.empty() || a.candidates.front().offset_s != applied_s) {
    throw_gap(a, file, fmt::format("the correction by {:+.0f} s leaves no frame inside the INS range", -applied_s));
  }
  if (config.enabled) {
    compare_by_data(frames, recorded, config, a);
    a.evidence = evidence_line(a);
    const double m = a.candidates.front().median_diff_deg;
    if (m > config.max_match_deg) {
      throw_gap(a, file, fmt::format("the LiDAR motion does not match the INS {:.0f} s apart either: {}", applied_s, a.evidence));
    }
    if (!std::isfinite(m)) a.warnings.push_back("clock correction not confirmed by the LiDAR motion: " + a.evidence);
  }
  take(a, a.candidates.front(), a.checked_by_data ? "confirmed by the LiDAR motion" : "from the recording's clock analysis");
  return a;
}

}  // namespace insalign::io
