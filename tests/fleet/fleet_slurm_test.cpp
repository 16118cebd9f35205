// A fleet on a real single-node Slurm cluster (scripts/fleet-services.sh): 13 rows of small drives
// over five cars, a knock on car B, a corrupt recording, and one task cancelled mid-run with
// scancel. Every other row is done exactly once; the cancelled one is failed, then retried.
#include <gtest/gtest.h>

#include <chrono>
#include <nlohmann/json.hpp>
#include <thread>

#include "fleet/status.hpp"
#include "fleet_test_util.hpp"
#include "files/read_file.hpp"

namespace insalign::testing {
namespace {

fleet::ManifestRow row_of(const std::string& car, const std::string& date) { return {car, date, "calibrate", "", "", "", 0}; }

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

TEST(FleetSlurm, ArrayJobWithAKnockACorruptRecordingAndACancelledTask) {
  if (std::getenv("INSALIGN_TEST_SLURM") == nullptr)
    GTEST_SKIP() << "INSALIGN_TEST_SLURM is not set (scripts/test.sh starts a single-node Slurm cluster and sets it)";
  const FleetDrives& d = fleet_drives();
  const std::vector<std::tuple<std::string, std::string, std::string>> rows{
      {"carA", "2026-01-01", "a"},         {"carA", "2026-01-08", "a"}, {"carA", "2026-01-15", "a"},
      {"carB", "2026-01-01", "b"},         {"carB", "2026-01-08", "b"}, {"carB", "2026-01-15", "b-knocked"},
      {"carB", "2026-01-22", "b-knocked"}, {"carC", "2026-01-01", "b"}, {"carC", "2026-01-08", "b"},
      {"carD", "2026-01-01", "a"},         {"carD", "2026-01-08", "corrupt"}, {"carE", "2026-01-01", "a"},
      {"carE", "2026-01-08", "a"}};
  std::string text;
  for (const auto& [car, date, drive] : rows) text += calibrate_row(car, date, drive);
  const fs::path manifest = write_manifest(d.dir / "slurm.csv", text);
  const fs::path results = fresh_dir("insalign_fleet_slurm", "");
  const std::string run = exe() + " fleet run " + manifest.string() + " --results " + results.string() +
                          " --engine slurm --wait --jobs 2 --cpus-per-task 1 --poll-s 0.5";

  // Row 0 is cancelled as soon as its task is mid-run.
  std::pair<int, std::string> first;
  std::thread fleet_run([&] { first = run_command(run); });
  bool cancelled = false;
  for (int i = 0; i < 1200 && !cancelled; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    const std::string job = array_job_id();
    if (!job.empty() && running(results / "carA", "2026-01-01-calibrate"))
      cancelled = run_command("scancel " + job + "_0").first == 0;
  }
  fleet_run.join();
  ASSERT_TRUE(cancelled) << first.second;
  EXPECT_EQ(first.first, 1) << first.second;
  EXPECT_TRUE(contains(first.second, "carA/2026-01-01-calibrate: CANCELLED")) << first.second;
  const std::string script = io::read_file(results / "slurm" / "fleet.sbatch");
  EXPECT_TRUE(contains(script, "#SBATCH --array=0-12%2")) << script;
  EXPECT_TRUE(contains(script, "#SBATCH --requeue"));
  EXPECT_TRUE(contains(script, "#SBATCH --time="));
  EXPECT_TRUE(contains(script, "#SBATCH --mem="));
  EXPECT_TRUE(contains(script, "logs/%A_%a.out"));
  const auto cancelled_status = fleet::read_status(results, row_of("carA", "2026-01-01"));
  if (cancelled_status) {  // SIGTERM reached the task: it recorded the signal
    EXPECT_EQ(cancelled_status->exit_code, 143);
    EXPECT_TRUE(contains(cancelled_status->error, "SIGTERM")) << cancelled_status->error;
  }
  EXPECT_FALSE(fs::exists(results / "carA" / "2026-01-01-calibrate"));  // no partial result
  std::map<std::string, std::string> started;
  for (std::size_t i = 1; i < rows.size(); ++i) {
    const auto& [car, date, drive] = rows[i];
    const auto s = fleet::read_status(results, row_of(car, date));
    ASSERT_TRUE(s.has_value()) << car << " " << date;
    EXPECT_EQ(s->attempts, 1) << s->id;
    started[s->id] = s->started;
    if (drive == "corrupt") {
      EXPECT_EQ(s->exit_code, 2);
      EXPECT_TRUE(contains(s->error, "corrupt/poses.txt") && contains(s->error, "line 20")) << s->error;
    } else {
      EXPECT_EQ(s->exit_code, 0) << s->id << ": " << s->error;
      EXPECT_TRUE(fs::exists(results / car / (date + "-calibrate") / "extrinsic.json"));
    }
  }
  EXPECT_FALSE(fs::is_empty(results / "slurm" / "logs"));

  // Run again: only the cancelled and the failed rows are submitted; the cancelled one is done now.
  const auto [rc2, out2] = run_command(run);
  EXPECT_EQ(rc2, 1) << out2;  // the corrupt recording still fails
  EXPECT_TRUE(contains(io::read_file(results / "slurm" / "fleet.sbatch"), "#SBATCH --array=0,10%2"));
  const auto retried = fleet::read_status(results, row_of("carA", "2026-01-01"));
  ASSERT_TRUE(retried.has_value());
  EXPECT_EQ(retried->exit_code, 0) << retried->error;
  EXPECT_EQ(retried->attempts, 2);
  for (std::size_t i = 1; i < rows.size(); ++i) {
    const auto& [car, date, drive] = rows[i];
    const auto s = fleet::read_status(results, row_of(car, date));
    if (drive != "corrupt") EXPECT_EQ(s->started, started[s->id]) << "done exactly once: " << s->id;
  }

  const auto [rc3, out3] = run_command(exe() + " fleet ingest --results " + results.string() + " && " + exe() +
                                       " fleet report --out " + results.string());
  ASSERT_EQ(rc3, 0) << out3;
  const nlohmann::json j = nlohmann::json::parse(io::read_file(results / "fleet.json"));
  EXPECT_EQ(j["cars_needing_recalibration"], 1);
  EXPECT_EQ(j["cars"][0]["car"], "carB");
  ASSERT_FALSE(j["cars"][0]["knocks"].empty());
  EXPECT_EQ(j["cars"][0]["knocks"][0]["date"], "2026-01-15");
  ASSERT_EQ(j["failed"].size(), 1u);
  EXPECT_EQ(j["failed"][0]["id"], "carD/2026-01-08-calibrate");
  EXPECT_TRUE(contains(j["failed"][0]["error"].get<std::string>(), "line 20"));
  EXPECT_EQ(j["runs"].size(), rows.size());
}

}  // namespace
}  // namespace insalign::testing
