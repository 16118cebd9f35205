// A fleet on a real single-node Slurm cluster (scripts/fleet-services.sh): 13 rows, 12 of them real
// `insalign check`s of small simulated city drives over five cars and several dates, car B knocked
// from its second date on, one corrupt recording, one calibration, and one task cancelled mid-run
// with scancel. Every other row is done exactly once; the cancelled one is failed, then retried;
// the dashboard flags car B from the checks and dates its knock.
#include <gtest/gtest.h>

#include <chrono>
#include <nlohmann/json.hpp>
#include <thread>

#include "fleet/engine_slurm.hpp"
#include "fleet/status.hpp"
#include "fleet_test_util.hpp"
#include "files/read_file.hpp"

namespace insalign::testing {
namespace {

bool running(const fs::path& car_dir, const std::string& stem) {
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(car_dir, ec))
    if (e.path().filename().string().rfind("." + stem + ".tmp-", 0) == 0) return true;
  return false;
}

std::string array_job_id() {
  const auto [rc, out] = run_command("squeue -h -n insalign-fleet -o %F | head -1");
  return rc == 0 ? out.substr(0, out.find_first_of(" \n")) : "";
}

struct Row {
  std::string car, date, kind, drive;
};

fleet::ManifestRow row_of(const Row& r) { return {r.car, r.date, r.kind, "", "", "", 0}; }

TEST(FleetSlurm, ArrayJobOfChecksWithAKnockACorruptRecordingAndACancelledTask) {
  if (std::getenv("INSALIGN_TEST_SLURM") == nullptr)
    GTEST_SKIP() << "INSALIGN_TEST_SLURM is not set (scripts/test.sh starts a single-node Slurm cluster and sets it)";
  const FleetDrives& d = fleet_drives();
  const std::vector<Row> rows{
      {"carA", "2026-01-01", "check", "u1"}, {"carA", "2026-01-08", "check", "u2"}, {"carA", "2026-01-15", "check", "u1"},
      {"carB", "2026-01-01", "check", "u2"}, {"carB", "2026-01-08", "check", "k1"}, {"carB", "2026-01-15", "check", "k2"},
      {"carC", "2026-01-01", "check", "u1"}, {"carC", "2026-01-08", "check", "u2"}, {"carD", "2026-01-01", "check", "u2"},
      {"carD", "2026-01-08", "check", "u1-corrupt"}, {"carE", "2026-01-01", "calibrate", "a"},
      {"carE", "2026-01-08", "check", "u1"}, {"carF", "2026-01-01", "check", "u3"}};
  std::string text;
  for (const Row& r : rows) text += r.kind == "check" ? check_row(d.dir, r.car, r.date, r.drive) : calibrate_row(r.car, r.date, r.drive);
  const fs::path manifest = write_manifest(d.dir / "slurm.csv", text);
  const ScratchDir scratch("insalign_fleet_slurm", "");
  const fs::path results = scratch.path();
  const std::string run = exe() + " fleet run " + manifest.string() + " --results " + results.string() +
                          " --engine slurm --wait --jobs 2 --cpus-per-task 1 --poll-s 0.5";

  // Row 0 is cancelled as soon as its task is mid-run.
  std::pair<int, std::string> first;
  std::thread fleet_run([&] { first = run_command(run); });
  bool cancelled = false;
  for (int i = 0; i < 2400 && !cancelled; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    const std::string job = array_job_id();
    if (!job.empty() && running(results / "carA", "2026-01-01-check")) cancelled = run_command("scancel " + job + "_0").first == 0;
  }
  fleet_run.join();
  ASSERT_TRUE(cancelled) << first.second;
  EXPECT_EQ(first.first, 1) << first.second;
  EXPECT_TRUE(contains(first.second, "carA/2026-01-01-check: CANCELLED")) << first.second;
  const std::string script = io::read_file(results / "slurm" / "fleet.sbatch");
  EXPECT_TRUE(contains(script, "#SBATCH --array=0-12%2")) << script;
  EXPECT_TRUE(contains(script, "#SBATCH --requeue"));
  EXPECT_TRUE(contains(script, "#SBATCH --time="));
  EXPECT_TRUE(contains(script, "#SBATCH --mem="));
  EXPECT_TRUE(contains(script, "logs/%A_%a.out"));
  const auto cancelled_status = fleet::read_status(results, row_of(rows[0]));
  if (cancelled_status) {  // SIGTERM reached the task: it recorded the signal
    EXPECT_EQ(cancelled_status->exit_code, 143);
    EXPECT_TRUE(contains(cancelled_status->error, "SIGTERM")) << cancelled_status->error;
  }
  EXPECT_FALSE(fs::exists(results / "carA" / "2026-01-01-check"));  // no partial result
  std::map<std::string, std::string> started;
  for (std::size_t i = 1; i < rows.size(); ++i) {
    const Row& r = rows[i];
    const auto s = fleet::read_status(results, row_of(r));
    ASSERT_TRUE(s.has_value()) << r.car << " " << r.date;
    EXPECT_EQ(s->attempts, 1) << s->id;
    started[s->id] = s->started;
    const fs::path out = results / r.car / (r.date + "-" + r.kind);
    if (r.drive == "u1-corrupt") {
      EXPECT_EQ(s->exit_code, 2);
      EXPECT_TRUE(contains(s->error, "u1-corrupt/poses_tum.txt") && contains(s->error, "line 20")) << s->error;
      EXPECT_FALSE(fs::exists(out));
    } else if (r.kind == "calibrate") {
      EXPECT_EQ(s->exit_code, 0) << s->id << ": " << s->error;
      EXPECT_TRUE(fs::exists(out / "extrinsic.json"));
    } else {  // the real check's verdict: recalibrate (exit 4) on the knocked drives, ok (exit 0) or inconclusive (3)
      const std::string expected = r.drive[0] == 'k' ? "recalibrate" : r.drive == "u3" ? "inconclusive" : "ok";
      EXPECT_EQ(s->exit_code, expected == "recalibrate" ? 4 : expected == "ok" ? 0 : 3) << s->id << ": " << s->error;
      ASSERT_TRUE(fs::exists(out / "check.json")) << s->id;
      const nlohmann::json c = nlohmann::json::parse(io::read_file(out / "check.json"));
      EXPECT_EQ(c["verdict"], expected) << s->id << ": " << c["message"];
      if (expected == "recalibrate") {
        EXPECT_EQ(c["dofs"]["yaw"]["verdict"], "drifted") << s->id;
      }
    }
  }
  EXPECT_FALSE(fs::is_empty(results / "slurm" / "logs"));

  // Run again: only the cancelled and the failed rows are submitted; the cancelled one is done now.
  const auto [rc2, out2] = run_command(run);
  EXPECT_EQ(rc2, 1) << out2;  // the corrupt recording still fails
  EXPECT_TRUE(contains(io::read_file(results / "slurm" / "fleet.sbatch"), "#SBATCH --array=0,9%2"));
  const auto retried = fleet::read_status(results, row_of(rows[0]));
  ASSERT_TRUE(retried.has_value());
  EXPECT_EQ(retried->exit_code, 0) << retried->error;
  EXPECT_EQ(retried->attempts, 2);
  for (std::size_t i = 1; i < rows.size(); ++i) {
    const auto s = fleet::read_status(results, row_of(rows[i]));
    if (rows[i].drive != "u1-corrupt") {
      EXPECT_EQ(s->started, started[s->id]) << "done exactly once: " << s->id;
    }
  }

  // The report of the results folder ingests its rows (sqlite:DIR/fleet.sqlite), then reports.
  const auto [rc3, out3] = run_command(exe() + " fleet report --out " + results.string());
  ASSERT_EQ(rc3, 0) << out3;
  EXPECT_TRUE(contains(out3, "13 new")) << out3;
  const nlohmann::json j = nlohmann::json::parse(io::read_file(results / "fleet.json"));
  EXPECT_EQ(j["cars_needing_recalibration"], 1);
  EXPECT_EQ(j["cars"][0]["car"], "carB");
  EXPECT_EQ(j["cars"][0]["state"], "recalibrate");
  ASSERT_EQ(j["cars"][0]["knocks"].size(), 1u);
  EXPECT_EQ(j["cars"][0]["knocks"][0]["date"], "2026-01-08");
  EXPECT_EQ(j["cars"][0]["knocks"][0]["after"], "2026-01-01");
  EXPECT_TRUE(contains(j["cars"][0]["knocks"][0]["what"].get<std::string>(), "yaw +0.")) << j["cars"][0]["knocks"][0];
  for (const auto& car : j["cars"])  // the unchanged cars: their latest check's verdict
    if (car["car"] != "carB") {
      EXPECT_EQ(car["state"], car["car"] == "carF" ? "inconclusive" : "ok") << car;
    }
  ASSERT_EQ(j["failed"].size(), 1u);
  EXPECT_EQ(j["failed"][0]["id"], "carD/2026-01-08-check");
  EXPECT_TRUE(contains(j["failed"][0]["error"].get<std::string>(), "line 20"));
  EXPECT_EQ(j["runs"].size(), rows.size());
}

// `scontrol show config` as Slurm 22.05 prints it, trimmed to the lines that matter here.
TEST(FleetSlurm, LatencyHintsNameWhatMakesTasksWaitForSlurmctldsPasses) {
  const std::string defaults =
      "Configuration data as of 2026-12-06T22:45:23\nEpilog                  = (null)\n"
      "EpilogMsgTime           = 2000 usec\nSchedulerParameters     = (null)\n";
  const std::vector<std::string> hints = fleet::slurm_latency_hints(defaults);
  ASSERT_EQ(hints.size(), 2u);
  EXPECT_NE(hints[0].find("Epilog=/bin/true"), std::string::npos) << hints[0];
  EXPECT_NE(hints[1].find("batch_sched_delay=0"), std::string::npos) << hints[1];
  EXPECT_TRUE(fleet::slurm_latency_hints("Epilog                  = /etc/slurm/epilog.sh\n"
                                         "SchedulerParameters     = bf_continue,batch_sched_delay=0\n")
                  .empty());
  EXPECT_TRUE(fleet::slurm_latency_hints("").empty());  // no scontrol output: nothing to say
}

TEST(FleetSlurm, TestClusterStartsAFreedSlotAtOnce) {
  if (std::getenv("INSALIGN_TEST_SLURM") == nullptr)
    GTEST_SKIP() << "INSALIGN_TEST_SLURM is not set (scripts/test.sh starts a single-node Slurm cluster and sets it)";
  for (const std::string& hint : fleet::slurm_latency_hints()) ADD_FAILURE() << "scripts/fleet-services.sh: " << hint;
}

}  // namespace
}  // namespace insalign::testing
