// insalign check on simulated ordinary drives (issue 38, item 5), in process: every drive is a
// fresh seeded world (scene, mount, noise) on one of the four ordinary trajectories, with a LiDAR
// model, an INS error model and traffic cycling over the drives. Even drives keep the installed
// extrinsic (false alarms: any DOF `drifted`), odd drives are knocked by 0.1 deg about one axis
// (roll, pitch, yaw in turn) and 2 cm along x or y (in turn): detection = `drifted` on the knocked
// DOFs where the drive did not call them `not-observable`. Coverage: |correction - knock| within
// 3 stated stddev, per DOF with a finite stddev. Prints markdown tables.
//
//   build/bench/check_accuracy --drives 100 --duration-s 180 --azimuth-step-deg 0.8
#include <CLI/CLI.hpp>
#include <fmt/core.h>

#include <array>
#include <chrono>
#include <map>
#include <memory>

#include "tool/tool_config.hpp"
#include "core/check_run.hpp"
#include "sim/world_dataset.hpp"

namespace insalign {
namespace {

struct Options {
  int drives = 100;
  int first = 0;
  double duration_s = 180.0;
  double azimuth_step_deg = 0.8;
};

const std::array<sim::TrajectoryKind, 4> kKinds{sim::TrajectoryKind::kCityLoop, sim::TrajectoryKind::kUrbanGrid,
                                               sim::TrajectoryKind::kHighway, sim::TrajectoryKind::kParkingLot};
const std::array<const char*, 4> kKindNames{"city-loop", "urban-grid", "highway", "parking-lot"};
const std::array<const char*, 4> kModels{"vlp16", "hdl32", "pandar64", "os1-64"};

struct DriveSpec {
  sim::SimConfig sim;
  bool knocked = false;
  Vec6 knock = Vec6::Zero();  // dx dy dz droll dpitch dyaw (m, deg)
  int kind = 0;
};

DriveSpec drive_spec(int i, const Options& o) {
  DriveSpec d;
  d.kind = i % 4;
  d.sim.seed = 1000 + static_cast<std::uint64_t>(i);
  d.sim.trajectory = kKinds[d.kind];
  d.sim.duration_s = o.duration_s;
  d.sim.lidar_model = kModels[(i / 4) % 4];
  d.sim.azimuth_step_deg = o.azimuth_step_deg;
  d.sim.ins_error.model = (i / 2) % 2 == 0 ? sim::InsErrorModel::kRtkFixed : sim::InsErrorModel::kDrift;
  d.sim.traffic = (i / 8) % 2 == 0 ? 8 : 0;
  d.sim.n_fiducials = 0;
  d.knocked = i % 2 == 1;
  if (d.knocked) {
    d.knock((i / 2) % 2) = 0.02;            // x or y
    d.knock(3 + (i / 2) % 3) = 0.1;         // roll, pitch or yaw
  }
  d.sim.knock = d.knock;
  return d;
}

struct Tally {
  int drives = 0, false_alarm_drives = 0;
  std::array<int, 7> observable{}, checked{}, detected{}, knocked_observable{}, covered{}, finite{};
};

void print_tables(const std::map<int, Tally>& by_kind, const Tally& all, int unchanged, int knocked) {
  fmt::print("\n| drive type | drives | observable (not `not-observable`) tx / ty / tz / roll / pitch / yaw / time |\n|---|---|---|\n");
  for (const auto& [k, t] : by_kind) {
    std::string row;
    for (int j = 0; j < 7; ++j) row += fmt::format("{}{:.0f}%", j ? " / " : "", 100.0 * t.observable[j] / std::max(1, t.drives));
    fmt::print("| {} | {} | {} |\n", kKindNames[k], t.drives, row);
  }
  fmt::print("\nfalse alarms: {} of {} unchanged drives ({:.1f}%) had a DOF `drifted`\n", all.false_alarm_drives, unchanged,
             100.0 * all.false_alarm_drives / std::max(1, unchanged));
  fmt::print("\n| DOF | knocked drives where observable | detected (`drifted`) | corrections within 3 stddev (all drives, finite stddev) |\n|---|---|---|---|\n");
  for (int j : {0, 1, 3, 4, 5, 6, 2}) {
    fmt::print("| {} | {} | {} | {} / {} ({:.0f}%) |\n", kCheckDofNames[j], all.knocked_observable[j],
               all.knocked_observable[j] ? fmt::format("{} ({:.0f}%)", all.detected[j], 100.0 * all.detected[j] / all.knocked_observable[j]) : "-",
               all.covered[j], all.finite[j], 100.0 * all.covered[j] / std::max(1, all.finite[j]));
  }
  fmt::print("\n({} knocked drives; each knocked by 0.1 deg about one rotation axis and 2 cm along x or y)\n", knocked);
}

int run(const Options& o) {
  cli::ToolConfig tool;
  std::map<int, Tally> by_kind;
  Tally all;
  int unchanged = 0, knocked = 0;
  fmt::print("| drive | type | LiDAR | INS | traffic | knock | verdict | drifted | not-observable | s |\n|---|---|---|---|---|---|---|---|---|---|\n");
  for (int i = o.first; i < o.first + o.drives; ++i) {
    const DriveSpec d = drive_spec(i, o);
    const auto t0 = std::chrono::steady_clock::now();
    auto world = std::make_shared<const sim::World>(sim::build_world(d.sim));
    Dataset data = sim::world_dataset(world);
    const Iso3 installed = world->lidars.front().T_ins_lidar_installed;
    data.T_ins_lidar_init = installed;
    const FrameStore store = make_frame_store(data, tool.calibrate);
    const CheckRun run = run_check(store, installed, world->lidars.front().time_offset_s, tool.calibrate, tool.check);
    const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    Tally& t = by_kind[d.kind];
    ++t.drives, ++all.drives;
    (d.knocked ? knocked : unchanged)++;
    std::string drifted, unseen;
    bool alarm = false;
    for (int j = 0; j < 7; ++j) {
      const DofCheck& c = run.findings.dofs[j];
      const bool observable = c.verdict != DofVerdictKind::kNotObservable;
      t.observable[j] += observable;
      if (c.verdict == DofVerdictKind::kDrifted) drifted += std::string(drifted.empty() ? "" : ",") + kCheckDofNames[j];
      if (!observable) unseen += std::string(unseen.empty() ? "" : ",") + kCheckDofNames[j];
      const double truth = j < 6 ? d.knock(j) : 0.0;
      if (!d.knocked && c.verdict == DofVerdictKind::kDrifted) alarm = true;
      if (d.knocked && truth != 0.0 && observable) {
        ++all.knocked_observable[j];
        all.detected[j] += c.verdict == DofVerdictKind::kDrifted;
      }
      if (std::isfinite(c.stddev)) {
        ++all.finite[j];
        all.covered[j] += std::abs(c.correction - truth) <= 3.0 * c.stddev;
      }
    }
    all.false_alarm_drives += alarm;
    fmt::print("| {} | {} | {} | {} | {} | {} | {} | {} | {} | {:.1f} |\n", i, kKindNames[d.kind], d.sim.lidar_model,
               d.sim.ins_error.model == sim::InsErrorModel::kDrift ? "drift" : "rtk", d.sim.traffic,
               d.knocked ? fmt::format("{:.2f} {:.2f} m, {:.1f} {:.1f} {:.1f} deg", d.knock(0), d.knock(1), d.knock(3),
                                       d.knock(4), d.knock(5))
                         : "none",
               enum_name(run.findings.verdict), drifted.empty() ? "-" : drifted, unseen.empty() ? "-" : unseen, wall);
    std::fflush(stdout);
  }
  print_tables(by_kind, all, unchanged, knocked);
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
  CLI11_PARSE(app, argc, argv);
  return insalign::run(o);
}
