// The history database (SQLite and PostgreSQL, one schema, migrations, idempotent and
// concurrent ingest) and the dashboard, on the results of a real local fleet run.
#include <gtest/gtest.h>

#include <unistd.h>

#include <fstream>
#include <nlohmann/json.hpp>
#include <thread>

#include "fleet/dashboard.hpp"
#include "fleet/ingest.hpp"
#include "fleet_test_util.hpp"
#include "files/read_file.hpp"

namespace insalign::testing {
namespace {

// Car A calibrated twice on one mount then checked (a real check: ok), car B calibrated before
// and after a knock, car C with a corrupt recording.
const fs::path& fleet_results() {
  static const ScratchDir scratch("insalign_fleet_history", "");  // removed at the process's exit
  static const fs::path results = [] {
    const FleetDrives& d = fleet_drives();
    // Its rows name the drives relative to it, so it lives beside them; one per process: the
    // tests of this file run at once and would rewrite one another's manifest while it is read.
    const fs::path manifest = write_manifest(d.dir / ("history-" + std::to_string(::getpid()) + ".csv"), calibrate_row("carA", "2026-01-01", "a") +
                                                                        calibrate_row("carA", "2026-01-08", "a") +
                                                                        calibrate_row("carB", "2026-01-01", "b") +
                                                                        calibrate_row("carB", "2026-01-15", "b-knocked") +
                                                                        calibrate_row("carC", "2026-01-02", "corrupt") +
                                                                        check_row(d.dir, "carA", "2026-01-22", "u1"));
    const fs::path r = scratch.path();
    const auto [rc, out] = run_command(exe() + " fleet run " + manifest.string() + " --results " + r.string() + " --jobs 2");
    EXPECT_EQ(rc, 1) << out;  // carC fails
    fs::remove(manifest);
    return r;
  }();
  return results;
}

TEST(FleetHistory, SqliteIngestIsIdempotentAndReplacesNewerAttempts) {
  const fs::path results = fleet_results();
  const ScratchDir scratch("insalign_fleet_sqlite", "");
  const fs::path db_path = scratch.path() / "fleet.sqlite";
  auto db = fleet::open_sqlite(db_path);
  fleet::IngestSummary first = fleet::ingest_results(results, *db);
  EXPECT_EQ(first.inserted, 6);
  EXPECT_TRUE(first.unreadable.empty());
  const auto runs = fleet::load_runs(*db);
  const auto extrinsics = fleet::load_extrinsics(*db);
  ASSERT_EQ(runs.size(), 6u);
  EXPECT_EQ(extrinsics.size(), 5u);  // one per done calibration and check, none for the failed row
  EXPECT_EQ(fleet::schema_version(*db), fleet::kSchemaVersion);
  for (const auto& r : runs) {
    EXPECT_EQ(r.verdict, r.car == "carC" ? "failed" : r.kind == "check" ? "ok" : "calibrated") << r.id;
    if (r.car == "carC") EXPECT_TRUE(contains(r.error, "line 20")) << r.error;
    else EXPECT_TRUE(contains(r.report, r.kind == "check" ? "check.html" : "report.html")) << r.report;
  }
  for (const auto& e : extrinsics) {  // the check's per-DOF corrections and verdicts are stored
    if (e.run_id != "carA/2026-01-22-check") continue;
    EXPECT_EQ(e.dof_verdict[5], "ok");
    ASSERT_TRUE(e.correction[5].has_value());
    EXPECT_LT(std::abs(*e.correction[5]), 0.05);
  }
  const fleet::IngestSummary again = fleet::ingest_results(results, *db);
  EXPECT_EQ(again.inserted + again.replaced, 0);
  EXPECT_EQ(again.unchanged, 6);
  EXPECT_EQ(fleet::load_runs(*db), runs);
  EXPECT_EQ(fleet::load_extrinsics(*db), extrinsics);

  // A newer attempt of a row (its status's "ended" differs) replaces the old run.
  const fs::path status = results / "carC" / "2026-01-02-calibrate.status.json";
  const std::string original = io::read_file(status);
  nlohmann::json j = nlohmann::json::parse(original);
  j["ended"] = "2099-01-01T00:00:00.000Z";
  std::ofstream(status) << j.dump();
  const fleet::IngestSummary newer = fleet::ingest_results(results, *db);
  std::ofstream(status) << original;
  EXPECT_EQ(newer.replaced, 1);
  EXPECT_EQ(fleet::load_runs(*db).size(), 6u);
}

TEST(FleetHistory, SchemaMigratesFromVersion1KeepingItsRows) {
  const ScratchDir scratch("insalign_fleet_migrate", "");
  const fs::path dir = scratch.path();
  auto db = fleet::open_sqlite(dir / "old.sqlite");
  EXPECT_EQ(fleet::migrate(*db, 1), 0);
  EXPECT_EQ(fleet::schema_version(*db), 1);
  db->query("INSERT INTO runs (id, car, date, kind, input, exit_code, verdict, error, started, ended) VALUES "
            "('c/2025-12-01-calibrate', 'c', '2025-12-01', 'calibrate', '--bag x.mcap', 0, 'calibrated', '', 's', 'e')",
            {});
  EXPECT_EQ(fleet::migrate(*db), 1);
  EXPECT_EQ(fleet::schema_version(*db), 2);
  const auto runs = fleet::load_runs(*db);
  ASSERT_EQ(runs.size(), 1u);
  EXPECT_EQ(runs[0].id, "c/2025-12-01-calibrate");
  EXPECT_EQ(runs[0].attempts, 0);  // the new column's default
  db->query("UPDATE schema_version SET version = 99", {});
  EXPECT_THROW(fleet::migrate(*db), fleet::DatabaseError);
}

TEST(FleetHistory, DashboardFlagsTheKnockedCarAndListsTheFailedRow) {
  const fs::path results = fleet_results();
  const ScratchDir scratch("insalign_fleet_report", "");
  const fs::path out = scratch.path();
  const auto [rc, text] = run_command(exe() + " fleet ingest --results " + results.string() + " --db sqlite:" + (out / "h.sqlite").string() +
                                      " && " + exe() + " fleet report --db sqlite:" + (out / "h.sqlite").string() + " --out " + out.string());
  ASSERT_EQ(rc, 0) << text;
  const nlohmann::json j = nlohmann::json::parse(io::read_file(out / "fleet.json"));
  ASSERT_EQ(j["cars"].size(), 3u);
  EXPECT_EQ(j["cars"][0]["car"], "carB");  // needing recalibration first
  EXPECT_TRUE(j["cars"][0]["needs_recalibration"].get<bool>());
  ASSERT_EQ(j["cars"][0]["knocks"].size(), 1u);
  EXPECT_EQ(j["cars"][0]["knocks"][0]["date"], "2026-01-15");
  EXPECT_TRUE(contains(j["cars"][0]["knocks"][0]["what"].get<std::string>(), "yaw +3")) << j["cars"][0]["knocks"][0]["what"];
  for (const auto& car : j["cars"]) {
    if (car["car"] == "carA") {
      EXPECT_FALSE(car["needs_recalibration"].get<bool>());
      EXPECT_TRUE(car["knocks"].empty());
      EXPECT_EQ(car["state"], "ok");  // its latest run, the check
      EXPECT_EQ(car["latest"]["date"], "2026-01-22");
      EXPECT_EQ(car["latest"]["report"], (fs::relative(results, out) / "carA/2026-01-22-check/check.html").string());
    }
    if (car["car"] == "carC") {
      EXPECT_EQ(car["state"], "failed");
    }
  }
  ASSERT_EQ(j["failed"].size(), 1u);
  EXPECT_EQ(j["failed"][0]["id"], "carC/2026-01-02-calibrate");
  const std::string html = io::read_file(out / "fleet.html");
  EXPECT_TRUE(contains(html, "<svg")) << "per-DOF plots";
  EXPECT_TRUE(contains(html, "class=\"band\""));
  EXPECT_TRUE(contains(html, "class=\"knock\""));
  EXPECT_TRUE(contains(html, "line 20"));  // the failed row's error
  EXPECT_LT(html.find("carB"), html.find("carA"));
}

// PostgreSQL: 4 ingests at once end in the same rows as SQLite; ingesting again changes nothing.
TEST(FleetHistory, PostgresConcurrentIngestsGiveTheSameRowsAsSqlite) {
  const char* url = std::getenv("INSALIGN_TEST_POSTGRES");
  if (url == nullptr) GTEST_SKIP() << "INSALIGN_TEST_POSTGRES is not set (scripts/test.sh starts a PostgreSQL server and sets it)";
  const fs::path results = fleet_results();
  const std::string name = "insalign_fleet_" + std::to_string(::getpid());
  auto admin = fleet::open_postgres(url);
  admin->query("DROP DATABASE IF EXISTS " + name, {});
  admin->query("CREATE DATABASE " + name, {});
  const std::string base(url);
  const std::string db_url = base.substr(0, base.rfind('/') + 1) + name;
  std::vector<std::thread> ingests;
  std::vector<std::pair<int, std::string>> outcomes(4);
  for (int i = 0; i < 4; ++i)
    ingests.emplace_back([&, i] { outcomes[i] = run_command(exe() + " fleet ingest --results " + results.string() + " --db " + db_url); });
  for (auto& t : ingests) t.join();
  int inserted = 0;
  for (const auto& [rc, out] : outcomes) {
    EXPECT_EQ(rc, 0) << out;
    inserted += contains(out, "6 new") ? 1 : 0;
  }
  EXPECT_EQ(inserted, 1);  // one ingest stored the rows; the other three found them there
  auto pg = fleet::open_postgres(db_url);
  const ScratchDir scratch("insalign_fleet_pg_vs", "");
  auto sqlite = fleet::open_sqlite(scratch.path() / "fleet.sqlite");
  fleet::ingest_results(results, *sqlite);
  const auto runs = fleet::load_runs(*pg);
  EXPECT_EQ(runs.size(), 6u);
  EXPECT_EQ(runs, fleet::load_runs(*sqlite));
  EXPECT_EQ(fleet::load_extrinsics(*pg), fleet::load_extrinsics(*sqlite));
  const fleet::IngestSummary again = fleet::ingest_results(results, *pg);
  EXPECT_EQ(again.unchanged, 6);
  EXPECT_EQ(fleet::load_runs(*pg), runs);
  pg.reset();
  admin->query("DROP DATABASE " + name, {});
}

}  // namespace
}  // namespace insalign::testing
