// The SQLite backend: the default database, one file beside the results.
#include <sqlite3.h>

#include <cstdio>

#include "core/errors.hpp"
#include "fleet/sql_connection.hpp"

namespace insalign::fleet {
namespace {

// "$1" is PostgreSQL's parameter; SQLite reads the same number as "?1".
std::string sqlite_placeholders(const std::string& sql) {
  std::string out = sql;
  for (std::size_t i = 0; i + 1 < out.size(); ++i)
    if (out[i] == '$' && out[i + 1] >= '0' && out[i + 1] <= '9') out[i] = '?';
  return out;
}

class SqliteConnection final : public SqlConnection {
 public:
  explicit SqliteConnection(const std::filesystem::path& path) : path_(path.string()) {
    if (sqlite3_open_v2(path_.c_str(), &db_, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE, nullptr) != SQLITE_OK) {
      const std::string why = db_ ? sqlite3_errmsg(db_) : "out of memory";
      sqlite3_close(db_);
      throw DatabaseError(path_ + ": cannot open the SQLite database: " + why);
    }
    sqlite3_busy_timeout(db_, 60000);  // concurrent ingests wait for each other
    query("PRAGMA foreign_keys = ON", {});
  }
  ~SqliteConnection() override { sqlite3_close(db_); }

  std::string dialect() const override { return "sqlite"; }

  std::vector<SqlRow> query(const std::string& sql, const std::vector<SqlValue>& params) override {
    sqlite3_stmt* stmt = nullptr;
    if (sqlite3_prepare_v2(db_, sqlite_placeholders(sql).c_str(), -1, &stmt, nullptr) != SQLITE_OK) fail(sql);
    for (std::size_t i = 0; i < params.size(); ++i) {
      const int at = static_cast<int>(i + 1);
      if (params[i]) sqlite3_bind_text(stmt, at, params[i]->c_str(), -1, SQLITE_TRANSIENT);
      else sqlite3_bind_null(stmt, at);
    }
    std::vector<SqlRow> rows;
    int rc;
    while ((rc = sqlite3_step(stmt)) == SQLITE_ROW) rows.push_back(read_row(stmt));
    sqlite3_finalize(stmt);
    if (rc != SQLITE_DONE) fail(sql);
    return rows;
  }

  void begin_exclusive() override { query("BEGIN IMMEDIATE", {}); }
  void commit() override { query("COMMIT", {}); }
  void rollback() override { query("ROLLBACK", {}); }

 private:
  static SqlRow read_row(sqlite3_stmt* stmt) {
    SqlRow row;
    for (int c = 0; c < sqlite3_column_count(stmt); ++c) {
      const int type = sqlite3_column_type(stmt, c);
      if (type == SQLITE_NULL) {
        row.push_back(std::nullopt);
      } else if (type == SQLITE_FLOAT) {
        char buf[40];  // SQLite's own text of a REAL keeps 15 digits; a double needs 17
        std::snprintf(buf, sizeof buf, "%.17g", sqlite3_column_double(stmt, c));
        row.push_back(std::string(buf));
      } else {
        row.push_back(std::string(reinterpret_cast<const char*>(sqlite3_column_text(stmt, c))));
      }
    }
    return row;
  }
  [[noreturn]] void fail(const std::string& sql) {
    throw DatabaseError(path_ + ": " + sqlite3_errmsg(db_) + " (in: " + sql.substr(0, 120) + ")");
  }

  std::string path_;
  sqlite3* db_ = nullptr;
};

}  // namespace

std::unique_ptr<SqlConnection> open_sqlite(const std::filesystem::path& path) { return std::make_unique<SqliteConnection>(path); }

std::unique_ptr<SqlConnection> open_database(const std::string& url, const std::filesystem::path& results) {
  if (url.empty()) return open_sqlite(results / "fleet.sqlite");
  if (url.rfind("sqlite:", 0) == 0) return open_sqlite(url.substr(7));
  if (url.rfind("postgresql://", 0) == 0 || url.rfind("postgres://", 0) == 0) return open_postgres(url);
  throw InputError(url, "", "not a database URL (sqlite:PATH or postgresql://user@host:port/database)");
}

}  // namespace insalign::fleet
