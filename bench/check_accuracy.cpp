// insalign check on simulated ordinary drives (issue 38, item 5), in process: every drive is a
// fresh seeded world (scene, mount, noise, time offset) on one of the four ordinary trajectories.
// The factors vary independently of each other: the drive type cycles (i % 4) and every other
// factor (knocked or not, INS error model, LiDAR model, traffic, mount, the knocked axes) is a
// balanced list shuffled with its own seed, so no factor rides along with another (the previous
// design tied the INS model to the drive type). Unchanged drives count false alarms (any DOF
// `drifted`); knocked drives (0.1 deg about one axis and 2 cm along x or y, truth = knock applied
// to the installed extrinsic) count detection = `drifted` on the knocked DOFs where the drive did
// not call them `not-observable`. Coverage: |correction - truth| within 3 stated stddev, per DOF
// with a finite stddev, the time offset included (the installed offset is the true one).
// Prints a row per drive and the tables every --tables-every drives (cumulative) and at the end.
// A run split over processes (--first, --drives, --threads 1, --jsonl) is tabled with --from-jsonl.
//
//   build/bench/check_accuracy --drives 100 --duration-s 180 --azimuth-step-deg 0.8
//   build/bench/check_accuracy --first 0 --drives 50 --threads 1 --jsonl a.jsonl   (and 50..99 into b.jsonl)
//   build/bench/check_accuracy --from-jsonl a.jsonl b.jsonl
#include <CLI/CLI.hpp>
#include <fmt/core.h>
#include <tbb/global_control.h>

#include <fstream>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <array>
#include <chrono>
#include <functional>
#include <map>
#include <memory>
#include <optional>

#include "core/check_run.hpp"
#include "sim/random.hpp"
#include "sim/world_dataset.hpp"
#include "tool/tool_config.hpp"

namespace insalign {
namespace {

struct Options {
  int drives = 100;
  int first = 0;
  double duration_s = 180.0;
  double azimuth_step_deg = 0.8;
  int tables_every = 20;
  int threads = 0;                     // 0: TBB's default
  std::string jsonl;                   // append one JSON line per drive here
  std::vector<std::string> from_jsonl; // only print the tables of these files' drives
  std::vector<std::string> set;        // key=value over the tool's defaults (as insalign --set)
  bool why = false;                    // print each drive's per-DOF reasons and warnings
};

const std::array<sim::TrajectoryKind, 4> kKinds{sim::TrajectoryKind::kCityLoop, sim::TrajectoryKind::kUrbanGrid,
                                               sim::TrajectoryKind::kHighway, sim::TrajectoryKind::kParkingLot};
const std::array<const char*, 4> kKindNames{"city-loop", "urban-grid", "highway", "parking-lot"};
const std::array<const char*, 4> kModels{"vlp16", "hdl32", "pandar64", "os1-64"};
// "roof": the single LiDAR's random roof mount (any yaw, roll and pitch within 10 deg); the others
// are rig mount presets (sim/rig.cpp) on a one-LiDAR rig, which also draws the LiDAR's clock offset.
const std::array<const char*, 4> kMounts{"roof", "roof-front", "front", "left"};

// Factor f of drive i: a balanced list of `levels` values over the run's indices [0, n), shuffled
// with the factor's own seed (Fisher-Yates on the simulator's counter-based generator).
int factor(int f, int i, int levels, int n) {
  std::vector<int> v(static_cast<std::size_t>(n));
  for (int k = 0; k < n; ++k) v[static_cast<std::size_t>(k)] = k % levels;
  sim::Rng rng(sim::hash_counters(0xC0FFEE, static_cast<std::uint64_t>(f)));
  for (int k = n - 1; k > 0; --k) std::swap(v[static_cast<std::size_t>(k)], v[static_cast<std::size_t>(rng.uniform_int(0, k))]);
  return v[static_cast<std::size_t>(i % n)];
}

struct DriveSpec {
  sim::SimConfig sim;
  bool knocked = false;
  Vec6 knock = Vec6::Zero();  // dx dy dz droll dpitch dyaw (m, deg)
  int kind = 0, model = 0, mount = 0;
};

DriveSpec drive_spec(int i, const Options& o) {
  constexpr int kDesign = 100;  // the shuffles' length: any 100 consecutive drives are balanced
  DriveSpec d;
  d.kind = i % 4;
  d.model = factor(2, i, 4, kDesign);
  d.mount = factor(5, i, 4, kDesign);
  d.sim.seed = 1000 + static_cast<std::uint64_t>(i);
  d.sim.trajectory = kKinds[static_cast<std::size_t>(d.kind)];
  d.sim.duration_s = o.duration_s;
  d.sim.lidar_model = kModels[static_cast<std::size_t>(d.model)];
  if (d.mount > 0) d.sim.rig = fmt::format("lidar:{}@{}", d.sim.lidar_model, kMounts[static_cast<std::size_t>(d.mount)]);
  d.sim.azimuth_step_deg = o.azimuth_step_deg;
  d.sim.ins_error.model = factor(3, i, 2, kDesign) == 0 ? sim::InsErrorModel::kRtkFixed : sim::InsErrorModel::kDrift;
  d.sim.traffic = factor(4, i, 2, kDesign) == 0 ? 8 : 0;
  d.sim.time_offset_s = sim::Rng(sim::hash_counters(0x0FF5E7, d.sim.seed)).uniform(-0.02, 0.02);
  d.sim.n_fiducials = 0;
  d.knocked = factor(1, i, 2, kDesign) == 1;
  if (d.knocked) {
    d.knock(factor(6, i, 2, kDesign)) = 0.02;         // x or y
    d.knock(3 + factor(7, i, 3, kDesign)) = 0.1;      // roll, pitch or yaw
  }
  d.sim.knock = d.knock;
  return d;
}

struct Tally {
  int drives = 0, false_alarm_drives = 0, unchanged = 0, knocked = 0;
  std::array<int, 7> observable{}, detected{}, knocked_observable{}, covered{}, finite{};
  std::array<std::vector<double>, 7> stddevs, errors;  // finite-stddev drives: stated stddev, correction - truth
  std::array<std::vector<double>, 7> honest_p;         // knocked, observable: P(detected) were the stddev honest
};

double normal_cdf(double x) { return 0.5 * std::erfc(-x / std::sqrt(2.0)); }

// Were the stated stddev honest (correction ~ N(truth, stddev)), the chance that a knocked DOF the
// check did not call `not-observable` is called `drifted`: P(drifted) / (P(drifted) + P(ok)). With
// the knock at the tolerance (2 cm for a 2 cm tolerance) half the corrections fall short of it and
// most of those are `not-observable`; `ok` takes those 2 stddev short: at best 1 - 0.023 / 0.523 =
// 95.6% for a small stddev, less for a larger one. The detection rate is read against this.
double honest_detection(double truth, double sd, double tolerance, const CheckConfig& c) {
  const double a = std::max(tolerance, c.drift_sigmas * sd), b = tolerance - c.ok_sigmas * sd;
  const double p_drifted = normal_cdf((-a - truth) / sd) + normal_cdf((truth - a) / sd);
  const double p_ok = b > 0.0 ? normal_cdf((b - truth) / sd) - normal_cdf((-b - truth) / sd) : 0.0;
  return p_drifted + p_ok > 0.0 ? p_drifted / (p_drifted + p_ok) : 0.0;
}

// P(at most k successes) of independent trials with these probabilities (Poisson binomial).
double at_most(const std::vector<double>& p, int k) {
  std::vector<double> dist{1.0};
  for (double q : p) {
    std::vector<double> next(dist.size() + 1, 0.0);
    for (std::size_t n = 0; n < dist.size(); ++n) next[n] += dist[n] * (1.0 - q), next[n + 1] += dist[n] * q;
    dist = std::move(next);
  }
  double sum = 0.0;
  for (int n = 0; n <= k && n < static_cast<int>(dist.size()); ++n) sum += dist[static_cast<std::size_t>(n)];
  return sum;
}

struct Row {
  std::array<DofCheck, 7> dofs;
  Vec7 truth = Vec7::Zero();
  bool knocked = false;
  std::map<std::string, std::string> levels;  // "drive type" -> "highway", "INS" -> "drift", ...
};

// A drive's row as one JSON line (--jsonl), so that runs split over processes can be tabled together.
nlohmann::json row_json(const Row& r) {
  nlohmann::json j{{"knocked", r.knocked}, {"levels", r.levels}};
  for (int k = 0; k < 7; ++k) {
    const DofCheck& c = r.dofs[k];
    j["dofs"].push_back({{"correction", c.correction}, {"stddev", std::isfinite(c.stddev) ? nlohmann::json(c.stddev) : nlohmann::json()},
                         {"verdict", enum_name(c.verdict)}, {"truth", r.truth(k)}});
  }
  return j;
}

Row row_from_json(const nlohmann::json& j) {
  Row r;
  r.knocked = j.at("knocked").get<bool>();
  r.levels = j.at("levels").get<std::map<std::string, std::string>>();
  for (int k = 0; k < 7; ++k) {
    const nlohmann::json& d = j.at("dofs").at(static_cast<std::size_t>(k));
    r.dofs[k].correction = d.at("correction").get<double>();
    r.dofs[k].stddev = d.at("stddev").is_null() ? std::numeric_limits<double>::infinity() : d.at("stddev").get<double>();
    r.dofs[k].verdict = d.at("verdict") == "ok" ? DofVerdictKind::kOk
                        : d.at("verdict") == "drifted" ? DofVerdictKind::kDrifted : DofVerdictKind::kNotObservable;
    r.truth(k) = d.at("truth").get<double>();
  }
  return r;
}

using Groups = std::map<std::string, std::map<std::string, Tally>>;  // "drive type", "INS", ... -> level -> tally

void add(Tally& t, const Row& r, const CheckConfig& check) {
  ++t.drives;
  (r.knocked ? t.knocked : t.unchanged)++;
  bool alarm = false;
  for (int j = 0; j < 7; ++j) {
    const DofCheck& c = r.dofs[j];
    const bool observable = c.verdict != DofVerdictKind::kNotObservable;
    t.observable[j] += observable;
    if (!r.knocked && c.verdict == DofVerdictKind::kDrifted) alarm = true;
    if (r.knocked && r.truth(j) != 0.0 && observable) {
      ++t.knocked_observable[j];
      t.detected[j] += c.verdict == DofVerdictKind::kDrifted;
      if (std::isfinite(c.stddev) && c.stddev > 0.0)
        t.honest_p[j].push_back(honest_detection(r.truth(j), c.stddev, dof_tolerance(j, check), check));
    }
    if (std::isfinite(c.stddev)) {
      ++t.finite[j];
      t.covered[j] += std::abs(c.correction - r.truth(j)) <= 3.0 * c.stddev;
      t.stddevs[j].push_back(c.stddev);
      t.errors[j].push_back(c.correction - r.truth(j));
    }
  }
  t.false_alarm_drives += alarm;
}

double median(std::vector<double> v) {
  if (v.empty()) return std::numeric_limits<double>::quiet_NaN();
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

double rms(const std::vector<double>& v) {
  double s = 0.0;
  for (double x : v) s += x * x;
  return v.empty() ? std::numeric_limits<double>::quiet_NaN() : std::sqrt(s / static_cast<double>(v.size()));
}

// Per DOF in a readable unit: mm, deg, ms.
double shown(int j, double v) { return j <= 2 ? 1e3 * v : j == 6 ? 1e3 * v : v; }
const char* shown_unit(int j) { return j <= 2 ? "mm" : j == 6 ? "ms" : "deg"; }

void print_observability(const char* title, const std::map<std::string, Tally>& groups) {
  fmt::print("\n| {} | drives | observable (not `not-observable`): tx / ty / tz / roll / pitch / yaw / time_offset |\n|---|---|---|\n", title);
  for (const auto& [k, t] : groups) {
    std::string row;
    for (int j = 0; j < 7; ++j) row += fmt::format("{}{:.0f}%", j ? " / " : "", 100.0 * t.observable[j] / std::max(1, t.drives));
    fmt::print("| {} | {} | {} |\n", k, t.drives, row);
  }
}

void print_tables(const Groups& groups, const Tally& all) {
  fmt::print("\n### After {} drives ({} unchanged, {} knocked)\n", all.drives, all.unchanged, all.knocked);
  fmt::print("\nfalse alarms: {} of {} unchanged drives ({:.1f}%) had a DOF `drifted`\n", all.false_alarm_drives,
             all.unchanged, 100.0 * all.false_alarm_drives / std::max(1, all.unchanged));
  fmt::print("\n| DOF | knocked, observable | detected (`drifted`) | expected were the stddevs honest (P of as few) | within 3 stddev of the truth (finite stddev) | median stated stddev | RMS error |\n|---|---|---|---|---|---|---|\n");
  for (int j : {0, 1, 3, 4, 5, 6, 2}) {
    const std::string detected = all.knocked_observable[j]
        ? fmt::format("{} ({:.0f}%)", all.detected[j], 100.0 * all.detected[j] / all.knocked_observable[j]) : "-";
    double expected = 0.0;
    for (double p : all.honest_p[j]) expected += p;
    const std::string honest = all.honest_p[j].empty() ? "-"
        : fmt::format("{:.1f} ({:.0f}%; {:.0f}%)", expected, 100.0 * expected / static_cast<double>(all.honest_p[j].size()),
                      100.0 * at_most(all.honest_p[j], all.detected[j]));
    fmt::print("| {} | {} | {} | {} | {} / {} ({:.0f}%) | {:.3g} {} | {:.3g} {} |\n", kCheckDofNames[j],
               all.knocked_observable[j], detected, honest, all.covered[j], all.finite[j],
               100.0 * all.covered[j] / std::max(1, all.finite[j]),
               shown(j, median(all.stddevs[j])), shown_unit(j), shown(j, rms(all.errors[j])), shown_unit(j));
  }
  for (const auto& [title, g] : groups) print_observability(title.c_str(), g);
  std::fflush(stdout);
}

std::string dof_list(const std::array<DofCheck, 7>& dofs, DofVerdictKind kind) {
  std::string out;
  for (int j = 0; j < 7; ++j)
    if (dofs[j].verdict == kind) out += std::string(out.empty() ? "" : ",") + kCheckDofNames[j];
  return out.empty() ? "-" : out;
}

void add_row(const Row& r, const CheckConfig& check, Groups& groups, Tally& all) {
  add(all, r, check);
  for (const auto& [factor_name, level] : r.levels) add(groups[factor_name][level], r, check);
}

int tables_from_jsonl(const Options& o) {
  const CheckConfig check = cli::tool_config_with(o.set).check.check;
  Groups groups;
  Tally all;
  for (const std::string& f : o.from_jsonl) {
    std::ifstream in(f);
    for (std::string line; std::getline(in, line);)
      if (!line.empty()) add_row(row_from_json(nlohmann::json::parse(line)), check, groups, all);
  }
  print_tables(groups, all);
  return 0;
}

int run(const Options& o) {
  if (!o.from_jsonl.empty()) return tables_from_jsonl(o);
  std::optional<tbb::global_control> threads;
  if (o.threads > 0) threads.emplace(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(o.threads));
  std::ofstream jsonl;
  if (!o.jsonl.empty()) jsonl.open(o.jsonl, std::ios::app);
  const cli::ToolConfig tool = cli::tool_config_with(o.set);
  Groups groups;
  Tally all;
  fmt::print("| drive | type | LiDAR | mount | INS | traffic | knock (m, deg) | verdict | drifted | not-observable | time offset err / sd (ms) | s |\n"
             "|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  for (int i = o.first; i < o.first + o.drives; ++i) {
    const DriveSpec d = drive_spec(i, o);
    const auto t0 = std::chrono::steady_clock::now();
    auto world = std::make_shared<const sim::World>(sim::build_world(d.sim));
    Dataset data = sim::world_dataset(world);
    const sim::SimLidar& lidar = world->lidars.front();
    data.T_ins_lidar_init = lidar.T_ins_lidar_installed;
    data.time_offset_init_s = lidar.time_offset_s;
    const FrameStore store = make_frame_store(data, tool.calibrate);
    const CheckRun run = run_check(store, lidar.T_ins_lidar_installed, lidar.time_offset_s, tool.calibrate, tool.check);
    const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    Row r{run.findings.dofs, Vec7::Zero(), d.knocked};
    r.truth.head<6>() = d.knock;
    const std::string ins = d.sim.ins_error.model == sim::InsErrorModel::kDrift ? "drift" : "rtk";
    r.levels = {{"drive type", kKindNames[static_cast<std::size_t>(d.kind)]}, {"INS", ins},
                {"mount", kMounts[static_cast<std::size_t>(d.mount)]}, {"LiDAR", kModels[static_cast<std::size_t>(d.model)]},
                {"traffic", fmt::format("{} vehicles", d.sim.traffic)}};
    add_row(r, tool.check.check, groups, all);
    if (jsonl) jsonl << row_json(r).dump() << std::endl;
    const DofCheck& off = run.findings.dofs[6];
    fmt::print("| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {:.1f} |\n", i,
               kKindNames[static_cast<std::size_t>(d.kind)], d.sim.lidar_model, kMounts[static_cast<std::size_t>(d.mount)],
               ins, d.sim.traffic,
               d.knocked ? fmt::format("{:.2f} {:.2f}, {:.1f} {:.1f} {:.1f}", d.knock(0), d.knock(1), d.knock(3), d.knock(4), d.knock(5))
                         : "none",
               enum_name(run.findings.verdict), dof_list(r.dofs, DofVerdictKind::kDrifted),
               dof_list(r.dofs, DofVerdictKind::kNotObservable),
               std::isfinite(off.stddev) ? fmt::format("{:.2f} / {:.2f}", 1e3 * off.correction, 1e3 * off.stddev) : "-", wall);
    if (o.why) {
      for (int j = 0; j < 7; ++j) fmt::print("    {}: {}\n", kCheckDofNames[j], run.findings.dofs[j].why);
      for (const std::string& w : run.findings.warnings) fmt::print("    warning: {}\n", w);
    }
    std::fflush(stdout);
    if (o.tables_every > 0 && (i - o.first + 1) % o.tables_every == 0 && i + 1 < o.first + o.drives) print_tables(groups, all);
  }
  print_tables(groups, all);
  return 0;
}

}  // namespace
}  // namespace insalign

int main(int argc, char** argv) {
  insalign::Options o;
  CLI::App app{"insalign check on simulated ordinary drives: false alarms, detection, coverage, observability"};
  app.add_option("--drives", o.drives, "drives to simulate and check");
  app.add_option("--first", o.first, "index of the first drive (seeds 1000 + index)");
  app.add_option("--duration-s", o.duration_s, "length of each drive, s");
  app.add_option("--azimuth-step-deg", o.azimuth_step_deg, "LiDAR horizontal resolution (reduced for speed), deg");
  app.add_option("--tables-every", o.tables_every, "print the cumulative tables every this many drives (0: at the end only)");
  app.add_option("--threads", o.threads, "at most this many threads (0: all cores)");
  app.add_option("--jsonl", o.jsonl, "append one JSON line per drive (its DOFs, truth and factors) to this file");
  app.add_option("--set", o.set, "KEY=VALUE over the defaults (as insalign --set), e.g. repeatability.segments=5");
  app.add_option("--from-jsonl", o.from_jsonl, "print the tables of the drives in these --jsonl files (no drive is run)");
  app.add_flag("--why", o.why, "print each drive's per-DOF reasons and warnings");
  CLI11_PARSE(app, argc, argv);
  return insalign::run(o);
}
