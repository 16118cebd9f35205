#include "fleet/database.hpp"

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <tuple>

namespace insalign::fleet {
namespace {

std::string real_type(SqlConnection& db) { return db.dialect() == "postgresql" ? "DOUBLE PRECISION" : "REAL"; }

std::string extrinsic_columns_ddl(const std::string& real) {
  std::string s;
  for (int i = 0; i < 16; ++i) s += ", m" + std::to_string(i) + " " + real + " NOT NULL";
  s += ", time_offset_s " + real;
  for (const char* d : kFleetDofs) s += std::string(", stddev_") + d + " " + real;
  for (const char* d : kFleetDofs) s += std::string(", determined_") + d + " INTEGER";
  for (const char* d : kFleetDofs) s += std::string(", correction_") + d + " " + real;
  for (const char* d : kFleetDofs) s += std::string(", verdict_") + d + " TEXT";
  return s;
}

void migration_1(SqlConnection& db) {
  db.query("CREATE TABLE schema_version (version INTEGER NOT NULL)", {});
  db.query("INSERT INTO schema_version (version) VALUES (0)", {});
  db.query("CREATE TABLE runs (id TEXT PRIMARY KEY, car TEXT NOT NULL, date TEXT NOT NULL, kind TEXT NOT NULL, "
           "input TEXT NOT NULL, exit_code INTEGER NOT NULL, verdict TEXT NOT NULL, error TEXT NOT NULL, "
           "started TEXT NOT NULL, ended TEXT NOT NULL)",
           {});
  db.query("CREATE TABLE extrinsics (run_id TEXT NOT NULL REFERENCES runs(id) ON DELETE CASCADE, lidar TEXT NOT NULL" +
               extrinsic_columns_ddl(real_type(db)) + ", PRIMARY KEY (run_id, lidar))",
           {});
  db.query("CREATE INDEX runs_by_car ON runs (car, date)", {});
}

void migration_2(SqlConnection& db) {
  db.query("ALTER TABLE runs ADD COLUMN attempts INTEGER NOT NULL DEFAULT 0", {});
  db.query("ALTER TABLE runs ADD COLUMN host TEXT NOT NULL DEFAULT ''", {});
  db.query("ALTER TABLE runs ADD COLUMN report TEXT NOT NULL DEFAULT ''", {});
}

const std::vector<std::function<void(SqlConnection&)>>& migrations() {
  static const std::vector<std::function<void(SqlConnection&)>> all{migration_1, migration_2};
  return all;
}

bool has_schema_table(SqlConnection& db) {
  const std::string sql = db.dialect() == "postgresql"
                              ? "SELECT 1 FROM information_schema.tables WHERE table_schema = current_schema() AND table_name = 'schema_version'"
                              : "SELECT 1 FROM sqlite_master WHERE type = 'table' AND name = 'schema_version'";
  return !db.query(sql, {}).empty();
}

std::string text(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}
SqlValue opt_text(const std::optional<double>& v) { return v ? SqlValue{text(*v)} : SqlValue{}; }
SqlValue opt_bool(const std::optional<bool>& v) { return v ? SqlValue{*v ? "1" : "0"} : SqlValue{}; }
SqlValue opt_string(const std::string& s) { return s.empty() ? SqlValue{} : SqlValue{s}; }
double to_double(const SqlValue& v) { return v ? std::strtod(v->c_str(), nullptr) : 0.0; }
std::optional<double> to_opt_double(const SqlValue& v) { return v ? std::optional<double>{std::strtod(v->c_str(), nullptr)} : std::nullopt; }
int to_int(const SqlValue& v) { return v ? std::atoi(v->c_str()) : 0; }

std::string placeholders(std::size_t from, std::size_t n) {
  std::string s;
  for (std::size_t i = 0; i < n; ++i) s += (i ? ", $" : "$") + std::to_string(from + i);
  return s;
}

std::string extrinsic_column_list() {
  std::string s = "run_id, lidar";
  for (int i = 0; i < 16; ++i) s += ", m" + std::to_string(i);
  s += ", time_offset_s";
  for (const char* prefix : {"stddev_", "determined_", "correction_", "verdict_"})
    for (const char* d : kFleetDofs) s += std::string(", ") + prefix + d;
  return s;
}
constexpr std::size_t kExtrinsicColumns = 2 + 16 + 1 + 4 * 7;

void insert_extrinsic(SqlConnection& db, const ExtrinsicRecord& e) {
  std::vector<SqlValue> p{e.run_id, e.lidar};
  for (double v : e.T_ins_lidar) p.push_back(text(v));
  p.push_back(opt_text(e.time_offset_s));
  for (const auto& v : e.stddev) p.push_back(opt_text(v));
  for (const auto& v : e.determined) p.push_back(opt_bool(v));
  for (const auto& v : e.correction) p.push_back(opt_text(v));
  for (const auto& v : e.dof_verdict) p.push_back(opt_string(v));
  db.query("INSERT INTO extrinsics (" + extrinsic_column_list() + ") VALUES (" + placeholders(1, kExtrinsicColumns) + ")", p);
}

}  // namespace

int schema_version(SqlConnection& db) {
  if (!has_schema_table(db)) return 0;
  const auto rows = db.query("SELECT version FROM schema_version", {});
  return rows.empty() ? 0 : to_int(rows[0][0]);
}

int migrate(SqlConnection& db, int target) {
  ExclusiveTransaction tx(db);  // concurrent first ingests: one migrates, the others then find it done
  const int found = schema_version(db);
  if (found > kSchemaVersion)
    throw DatabaseError("the database's schema is version " + std::to_string(found) + ", newer than this insalign's " +
                        std::to_string(kSchemaVersion) + ": use a newer insalign");
  for (int v = found; v < target; ++v) {
    migrations()[static_cast<std::size_t>(v)](db);
    db.query("UPDATE schema_version SET version = $1", {std::to_string(v + 1)});
  }
  tx.commit();
  return found;
}

StoreOutcome store_run(SqlConnection& db, const RunRecord& r, const std::vector<ExtrinsicRecord>& extrinsics) {
  const auto existing = db.query("SELECT ended FROM runs WHERE id = $1", {r.id});
  if (!existing.empty() && existing[0][0] == SqlValue{r.ended}) return StoreOutcome::kUnchanged;
  db.query("DELETE FROM extrinsics WHERE run_id = $1", {r.id});
  db.query("INSERT INTO runs (id, car, date, kind, input, exit_code, verdict, error, started, ended, attempts, host, report) "
           "VALUES ($1, $2, $3, $4, $5, $6, $7, $8, $9, $10, $11, $12, $13) ON CONFLICT (id) DO UPDATE SET "
           "car = excluded.car, date = excluded.date, kind = excluded.kind, input = excluded.input, "
           "exit_code = excluded.exit_code, verdict = excluded.verdict, error = excluded.error, "
           "started = excluded.started, ended = excluded.ended, attempts = excluded.attempts, host = excluded.host, "
           "report = excluded.report",
           {r.id, r.car, r.date, r.kind, r.input, std::to_string(r.exit_code), r.verdict, r.error, r.started, r.ended,
            std::to_string(r.attempts), r.host, r.report});
  for (const ExtrinsicRecord& e : extrinsics) insert_extrinsic(db, e);
  return existing.empty() ? StoreOutcome::kInserted : StoreOutcome::kReplaced;
}

std::vector<RunRecord> load_runs(SqlConnection& db) {
  std::vector<RunRecord> out;
  for (const SqlRow& r : db.query("SELECT id, car, date, kind, input, exit_code, verdict, error, started, ended, attempts, "
                                  "host, report FROM runs ORDER BY car, date, id",
                                  {})) {
    out.push_back({*r[0], *r[1], *r[2], *r[3], *r[4], to_int(r[5]), *r[6], *r[7], *r[8], *r[9], to_int(r[10]), *r[11], *r[12]});
  }
  // Sorted here, not by the server: PostgreSQL's collation follows its locale, SQLite's is bytes.
  std::sort(out.begin(), out.end(), [](const RunRecord& a, const RunRecord& b) {
    return std::tie(a.car, a.date, a.id) < std::tie(b.car, b.date, b.id);
  });
  return out;
}

std::vector<ExtrinsicRecord> load_extrinsics(SqlConnection& db) {
  std::vector<ExtrinsicRecord> out;
  for (const SqlRow& r : db.query("SELECT " + extrinsic_column_list() + " FROM extrinsics ORDER BY run_id, lidar", {})) {
    ExtrinsicRecord e;
    e.run_id = *r[0];
    e.lidar = *r[1];
    std::size_t c = 2;
    for (double& v : e.T_ins_lidar) v = to_double(r[c++]);
    e.time_offset_s = to_opt_double(r[c++]);
    for (auto& v : e.stddev) v = to_opt_double(r[c++]);
    for (auto& v : e.determined) v = r[c] ? std::optional<bool>{to_int(r[c]) != 0} : std::nullopt, ++c;
    for (auto& v : e.correction) v = to_opt_double(r[c++]);
    for (auto& v : e.dof_verdict) v = r[c].value_or(""), ++c;
    out.push_back(std::move(e));
  }
  std::sort(out.begin(), out.end(), [](const ExtrinsicRecord& a, const ExtrinsicRecord& b) {
    return std::tie(a.run_id, a.lidar) < std::tie(b.run_id, b.lidar);
  });
  return out;
}

}  // namespace insalign::fleet
