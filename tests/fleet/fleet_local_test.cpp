// The local engine and the task on real simulated drives: every row done once, bad rows failed
// with their reason, a killed task leaves nothing half-written and is retried.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>

#include <chrono>
#include <thread>

#include "core/geometry.hpp"
#include "fleet/process.hpp"
#include "fleet/status.hpp"
#include "fleet_test_util.hpp"
#include "files/extrinsic_json.hpp"

namespace insalign::testing {
namespace {

using fleet::ManifestRow;

fleet::TaskStatus status_of(const fs::path& results, const std::string& car, const std::string& stem) {
  ManifestRow row;
  row.car = car;
  row.date = stem.substr(0, stem.rfind('-'));
  row.kind = stem.substr(stem.rfind('-') + 1);
  const auto s = fleet::read_status(results, row);
  EXPECT_TRUE(s.has_value()) << car << "/" << stem;
  return s.value_or(fleet::TaskStatus{});
}

bool has_temporaries(const fs::path& dir) {
  for (const auto& e : fs::recursive_directory_iterator(dir))
    if (e.path().filename().string().find(".tmp-") != std::string::npos) return true;
  return false;
}

// The calibration a done row holds is the drive's truth (a real result, not just a file).
void expect_near_truth(const fs::path& row_dir, const fs::path& drive) {
  const Iso3 T_est = io::read_extrinsic_file(row_dir / "extrinsic.json").T_ins_lidar;
  const Iso3 T_gt = io::read_extrinsic_file(drive / "ground_truth.json").T_ins_lidar;
  const double angle_deg = Eigen::AngleAxisd(T_est.linear() * T_gt.linear().transpose()).angle() * kDegPerRad;
  EXPECT_LT(angle_deg, 1.0) << row_dir;
  EXPECT_LT((T_est.translation() - T_gt.translation()).norm(), 0.2) << row_dir;
}

TEST(FleetLocal, EveryRowDoneOnceBadRecordingsFailWithTheirReason) {
  const FleetDrives& d = fleet_drives();
  const fs::path manifest = write_manifest(d.dir / "local.csv", calibrate_row("carA", "2026-01-01", "a") +
                                                                    calibrate_row("carA", "2026-01-08", "a") +
                                                                    calibrate_row("carB", "2026-01-01", "b") +
                                                                    calibrate_row("carC", "2026-01-01", "corrupt") +
                                                                    calibrate_row("carD", "2026-01-01", "nowhere"));
  const ScratchDir scratch("insalign_fleet_local", "");
  const fs::path results = scratch.path();
  const std::string run = exe() + " fleet run " + manifest.string() + " --results " + results.string() + " --jobs 2";
  const auto [rc, out] = run_command(run);
  EXPECT_EQ(rc, 1) << out;  // two rows failed: the fleet ran to its end and says so
  EXPECT_TRUE(contains(out, "5 rows: 3 done, 2 failed")) << out;
  for (const auto& [car, drive] : {std::pair{"carA", "a"}, {"carB", "b"}}) {
    const fleet::TaskStatus s = status_of(results, car, "2026-01-01-calibrate");
    EXPECT_EQ(s.exit_code, 0) << s.error;
    EXPECT_EQ(s.attempts, 1);
    expect_near_truth(results / car / "2026-01-01-calibrate", d.dir / drive);
  }
  const fleet::TaskStatus corrupt = status_of(results, "carC", "2026-01-01-calibrate");
  EXPECT_EQ(corrupt.exit_code, 2);
  EXPECT_TRUE(contains(corrupt.error, "corrupt/poses.txt") && contains(corrupt.error, "line 20")) << corrupt.error;
  EXPECT_FALSE(fs::exists(results / "carC" / "2026-01-01-calibrate"));  // no outputs for a failed row
  EXPECT_TRUE(fs::exists(results / "carC" / "2026-01-01-calibrate.log"));
  const fleet::TaskStatus missing = status_of(results, "carD", "2026-01-01-calibrate");
  EXPECT_EQ(missing.exit_code, 2);
  EXPECT_TRUE(contains(missing.error, "nowhere/lidar")) << missing.error;
  EXPECT_FALSE(has_temporaries(results));

  // Again: done rows are skipped (their status untouched), failed rows are retried.
  const std::string started = status_of(results, "carA", "2026-01-08-calibrate").started;
  const auto [rc2, out2] = run_command(run);
  EXPECT_EQ(rc2, 1) << out2;
  EXPECT_EQ(status_of(results, "carA", "2026-01-08-calibrate").started, started);
  EXPECT_EQ(status_of(results, "carA", "2026-01-08-calibrate").attempts, 1);
  EXPECT_EQ(status_of(results, "carC", "2026-01-01-calibrate").attempts, 2);

  // --force reruns a done row in place.
  const fs::path one = write_manifest(d.dir / "local-one.csv", calibrate_row("carA", "2026-01-08", "a"));
  const auto [rc3, out3] = run_command(exe() + " fleet run " + one.string() + " --results " + results.string() + " --force");
  EXPECT_EQ(rc3, 0) << out3;
  const fleet::TaskStatus forced = status_of(results, "carA", "2026-01-08-calibrate");
  EXPECT_EQ(forced.attempts, 2);
  EXPECT_NE(forced.started, started);
  expect_near_truth(results / "carA" / "2026-01-08-calibrate", d.dir / "a");
}

// Waits until the row's temporary folder exists: the task is mid-run.
bool wait_for_temporary(const fs::path& car_dir) {
  for (int i = 0; i < 600; ++i) {
    if (fs::exists(car_dir) && has_temporaries(car_dir)) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  return false;
}

TEST(FleetLocal, AKilledTaskLeavesNoPartialResultAndIsRetried) {
  const FleetDrives& d = fleet_drives();
  const fs::path manifest = write_manifest(d.dir / "kill.csv", calibrate_row("carK", "2026-02-01", "a"));
  const ScratchDir scratch("insalign_fleet_kill", "");
  const fs::path results = scratch.path();
  const std::vector<std::string> task{exe(), "fleet", "task", manifest.string(), "--results", results.string(), "--index", "0"};

  // SIGTERM (scancel, a time limit): the command is stopped, the temporary folder removed, the signal recorded.
  pid_t pid = fleet::spawn({task, {}, results / "task.log"});
  ASSERT_TRUE(wait_for_temporary(results / "carK"));
  ::kill(pid, SIGTERM);
  EXPECT_EQ(fleet::wait_exit_code(pid), 128 + SIGTERM);
  fleet::TaskStatus s = status_of(results, "carK", "2026-02-01-calibrate");
  EXPECT_EQ(s.exit_code, 128 + SIGTERM);
  EXPECT_TRUE(contains(s.error, "SIGTERM")) << s.error;
  EXPECT_FALSE(fs::exists(results / "carK" / "2026-02-01-calibrate"));
  EXPECT_FALSE(has_temporaries(results));

  // SIGKILL (a lost node): nothing is published; the command dies with its task.
  pid = fleet::spawn({task, {}, results / "task.log"});
  ASSERT_TRUE(wait_for_temporary(results / "carK"));
  ::kill(pid, SIGKILL);
  EXPECT_EQ(fleet::wait_exit_code(pid), 128 + SIGKILL);
  EXPECT_FALSE(fs::exists(results / "carK" / "2026-02-01-calibrate"));
  EXPECT_EQ(status_of(results, "carK", "2026-02-01-calibrate").attempts, 1);  // the killed attempt wrote nothing

  // The retry cleans up and finishes; the index comes from the engine's variable.
  ::setenv("JOB_COMPLETION_INDEX", "0", 1);
  const auto [rc, out] = run_command(exe() + " fleet task " + manifest.string() + " --results " + results.string());
  ::unsetenv("JOB_COMPLETION_INDEX");
  EXPECT_EQ(rc, 0) << out;
  s = status_of(results, "carK", "2026-02-01-calibrate");
  EXPECT_EQ(s.exit_code, 0) << s.error;
  EXPECT_EQ(s.attempts, 3);
  EXPECT_FALSE(has_temporaries(results));
  expect_near_truth(results / "carK" / "2026-02-01-calibrate", d.dir / "a");
}

TEST(FleetLocal, AMalformedManifestExits2BeforeAnythingRuns) {
  const FleetDrives& d = fleet_drives();
  const fs::path manifest =
      write_manifest(d.dir / "dup.csv", calibrate_row("carX", "2026-01-01", "a") + calibrate_row("carX", "2026-01-01", "b"));
  const ScratchDir scratch("insalign_fleet_dup", "");
  const fs::path results = scratch.path();
  const auto [rc, out] = run_command(exe() + " fleet run " + manifest.string() + " --results " + results.string());
  EXPECT_EQ(rc, 2) << out;
  EXPECT_TRUE(contains(out, "dup.csv:line 3, column 1: duplicate id carX/2026-01-01-calibrate (lines 2 and 3)")) << out;
  EXPECT_FALSE(fs::exists(results / "carX"));
  const auto [rc2, out2] = run_command(exe() + " fleet task " + manifest.string() + " --results " + results.string() + " --index 0");
  EXPECT_EQ(rc2, 2) << out2;
}

}  // namespace
}  // namespace insalign::testing
