// Check rows end to end on the local engine: real `insalign check` runs of small simulated
// ordinary drives (three cars, car1 knocked from its second date on), then `fleet report` on the
// results folder, which ingests them: car1 is flagged from its checks and its knock dated.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "fleet/status.hpp"
#include "fleet_test_util.hpp"
#include "files/read_file.hpp"

namespace insalign::testing {
namespace {

using nlohmann::json;

json check_json(const fs::path& results, const std::string& car, const std::string& date) {
  return json::parse(io::read_file(results / car / (date + "-check") / "check.json"));
}

TEST(FleetCheckRows, RealChecksFlagTheKnockedCarAndDateItsKnock) {
  const FleetDrives& d = fleet_drives();
  const fs::path manifest =
      write_manifest(d.dir / "checks.csv", check_row(d.dir, "car1", "2026-02-01", "u1") + check_row(d.dir, "car1", "2026-02-08", "k1") +
                                               check_row(d.dir, "car1", "2026-02-15", "k2") +
                                               check_row(d.dir, "car2", "2026-02-01", "u2") +
                                               check_row(d.dir, "car3", "2026-02-08", "u3"));
  const ScratchDir scratch("insalign_fleet_checks", "");
  const fs::path results = scratch.path();
  const auto [rc, out] = run_command(exe() + " fleet run " + manifest.string() + " --results " + results.string() + " --jobs 2");
  EXPECT_EQ(rc, 0) << out;
  EXPECT_TRUE(contains(out, "5 rows: 5 done")) << out;

  // The checks themselves: ok where the mount is the installed one and the drive decides it,
  // inconclusive where it does not (u3), the knock measured where the mount moved.
  for (const auto& [car, date] : {std::pair{"car1", "2026-02-01"}, {"car2", "2026-02-01"}}) {
    const json c = check_json(results, car, date);
    EXPECT_EQ(c["verdict"], "ok") << car << " " << date << ": " << c["message"];
  }
  EXPECT_EQ(check_json(results, "car3", "2026-02-08")["verdict"], "inconclusive");
  for (const char* date : {"2026-02-08", "2026-02-15"}) {
    const json c = check_json(results, "car1", date);
    EXPECT_EQ(c["verdict"], "recalibrate") << date << ": " << c["message"];
    const json& yaw = c["dofs"]["yaw"];
    EXPECT_EQ(yaw["verdict"], "drifted") << date;
    EXPECT_LE(std::abs(yaw["correction"].get<double>() - 0.6), 3.0 * yaw["stddev"].get<double>()) << date << ": " << yaw;
  }

  const auto [rc2, out2] = run_command(exe() + " fleet report --out " + results.string());
  ASSERT_EQ(rc2, 0) << out2;
  EXPECT_TRUE(contains(out2, "ingested " + results.string() + ": 5 new")) << out2;
  const json j = json::parse(io::read_file(results / "fleet.json"));
  EXPECT_EQ(j["cars_needing_recalibration"], 1);
  ASSERT_EQ(j["cars"].size(), 3u);
  const json& car1 = j["cars"][0];
  EXPECT_EQ(car1["car"], "car1");
  EXPECT_EQ(car1["state"], "recalibrate");
  EXPECT_TRUE(car1["needs_recalibration"].get<bool>());
  ASSERT_EQ(car1["knocks"].size(), 1u);  // the second recalibrate is the same knock
  EXPECT_EQ(car1["knocks"][0]["date"], "2026-02-08");
  EXPECT_EQ(car1["knocks"][0]["after"], "2026-02-01");
  EXPECT_TRUE(contains(car1["knocks"][0]["what"].get<std::string>(), "yaw +0.")) << car1["knocks"][0];
  EXPECT_EQ(car1["series"]["lidar"]["yaw"].size(), 3u);  // one correction per check, plotted
  for (std::size_t i : {1u, 2u}) {
    EXPECT_EQ(j["cars"][i]["state"], j["cars"][i]["car"] == "car3" ? "inconclusive" : "ok") << j["cars"][i];
    EXPECT_FALSE(j["cars"][i]["needs_recalibration"].get<bool>());
  }
  for (const json& run : j["runs"]) EXPECT_TRUE(contains(run["report"].get<std::string>(), "check.html")) << run;
  EXPECT_TRUE(j["failed"].empty());

  // Reporting again ingests nothing new.
  const auto [rc3, out3] = run_command(exe() + " fleet report --out " + results.string());
  EXPECT_EQ(rc3, 0) << out3;
  EXPECT_TRUE(contains(out3, "0 new, 0 replaced, 5 unchanged")) << out3;
}

}  // namespace
}  // namespace insalign::testing
