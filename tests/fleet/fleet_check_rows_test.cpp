// Check rows in the history and the dashboard. `insalign check` is built on another branch; until
// it is merged, its outputs here are check.json files of the contract's shape (CONVENTIONS.md
// "Checking an installed extrinsic") written by the test: the one stand-in of the fleet's tests.
#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>

#include "fleet/fleet_summary.hpp"
#include "fleet/ingest.hpp"
#include "fleet_test_util.hpp"

namespace insalign::testing {
namespace {

using nlohmann::json;

// A check of car `car` on `date`: yaw corrected by `yaw_deg` +- 0.02 deg, the rest within tolerance.
void write_check(const fs::path& results, const std::string& car, const std::string& date, double yaw_deg) {
  fleet::TaskStatus s;
  s.row = {car, date, "check", "--bag drives/" + car + "-" + date + ".mcap", "installed/" + car + ".json", "", 2};
  s.id = s.row.id();
  const bool drifted = std::abs(yaw_deg) > 0.05;
  s.exit_code = drifted ? 4 : 0;
  s.attempts = 1;
  s.host = "test";
  s.started = date + "T10:00:00.000Z";
  s.ended = date + "T10:01:00.000Z";
  json dofs;
  for (const char* d : {"tx", "ty", "tz", "roll", "pitch", "yaw", "time_offset"}) {
    const bool yaw = std::string(d) == "yaw";
    dofs[d] = {{"correction", yaw ? yaw_deg : 0.001}, {"stddev", 0.02}, {"unit", "deg"},
               {"verdict", yaw && drifted ? "drifted" : "ok"}, {"why", ""}};
  }
  const json T = json::array({json::array({1, 0, 0, 0.5}), json::array({0, 1, 0, 0.1}), json::array({0, 0, 1, 1.6}),
                              json::array({0, 0, 0, 1})});
  const json check = {{"verdict", drifted ? "recalibrate" : "ok"}, {"checked", {{"T_ins_lidar", T}, {"source", "installed.json"}}},
                      {"dofs", dofs}, {"corrected", {{"T_ins_lidar", T}, {"time_offset_s", 0.0}}}, {"drives", 1}};
  const fs::path dir = fleet::row_dir(results, s.row);
  fs::create_directories(dir);
  std::ofstream(dir / "check.json") << check.dump();
  std::ofstream(dir / "check.html") << "<html></html>";
  fleet::write_status(results, s);
}

TEST(FleetCheckRows, AKnockSeenByTheChecksIsDatedAndFlagged) {
  const fs::path results = fresh_dir("insalign_fleet_checks", "");
  write_check(results, "car1", "2026-02-01", 0.01);
  write_check(results, "car1", "2026-02-08", -0.02);
  write_check(results, "car1", "2026-02-15", 1.2);  // the knock
  write_check(results, "car1", "2026-02-22", 1.18);
  write_check(results, "car2", "2026-02-01", 0.0);
  write_check(results, "car2", "2026-02-08", 0.01);
  auto db = fleet::open_sqlite(results / "fleet.sqlite");
  EXPECT_EQ(fleet::ingest_results(results, *db).inserted, 6);
  const auto runs = fleet::load_runs(*db);
  const auto extrinsics = fleet::load_extrinsics(*db);
  ASSERT_EQ(extrinsics.size(), 6u);
  EXPECT_EQ(extrinsics[2].dof_verdict[5], "drifted");
  EXPECT_DOUBLE_EQ(*extrinsics[2].correction[5], 1.2);
  EXPECT_EQ(runs[2].verdict, "recalibrate");
  EXPECT_TRUE(contains(runs[2].report, "check.html"));
  const fleet::FleetSummary s = fleet::summarize_fleet(runs, extrinsics);
  ASSERT_EQ(s.cars.size(), 2u);
  EXPECT_EQ(s.cars[0].car, "car1");
  EXPECT_EQ(s.cars[0].state, "recalibrate");
  EXPECT_TRUE(s.cars[0].needs_recalibration);
  ASSERT_EQ(s.cars[0].knocks.size(), 1u);  // the second recalibrate is the same knock
  EXPECT_EQ(s.cars[0].knocks[0].date, "2026-02-15");
  EXPECT_EQ(s.cars[0].knocks[0].after, "2026-02-08");
  EXPECT_TRUE(contains(s.cars[0].knocks[0].what, "yaw +1.200 deg")) << s.cars[0].knocks[0].what;
  EXPECT_EQ(s.cars[0].series.at("lidar")[5].size(), 4u);
  EXPECT_EQ(s.cars[1].state, "ok");
  EXPECT_FALSE(s.cars[1].needs_recalibration);
}

}  // namespace
}  // namespace insalign::testing
