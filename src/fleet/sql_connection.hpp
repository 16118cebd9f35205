// One interface to the history database, two backends: SQLite (a file, the default) and
// PostgreSQL (through libpq). Statements use $1..$N parameters in both.
#pragma once

#include <filesystem>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace insalign::fleet {

using SqlValue = std::optional<std::string>;  ///< a parameter or a cell as text; nullopt is NULL
using SqlRow = std::vector<SqlValue>;

/// A database that refused a statement or a connection; the message has the server's words.
class DatabaseError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class SqlConnection {
 public:
  virtual ~SqlConnection() = default;
  virtual std::string dialect() const = 0;  ///< "sqlite" or "postgresql"
  /// Runs one statement; its rows (floating-point cells in full precision). Throws DatabaseError.
  virtual std::vector<SqlRow> query(const std::string& sql, const std::vector<SqlValue>& params = {}) = 0;
  /// Starts a write transaction that excludes every other writer until commit or rollback
  /// (SQLite: BEGIN IMMEDIATE; PostgreSQL: BEGIN and a transaction advisory lock).
  virtual void begin_exclusive() = 0;
  virtual void commit() = 0;
  virtual void rollback() = 0;
};

/// Opens (creating) an SQLite database file.
std::unique_ptr<SqlConnection> open_sqlite(const std::filesystem::path& path);

/// Connects to PostgreSQL; `conninfo` is a libpq URI (postgresql://user@host:port/db) or key=value string.
std::unique_ptr<SqlConnection> open_postgres(const std::string& conninfo);

/// `sqlite:PATH`, `postgresql://...` (or `postgres://...`); an empty URL is sqlite:RESULTS/fleet.sqlite.
/// Throws InputError for any other URL.
std::unique_ptr<SqlConnection> open_database(const std::string& url, const std::filesystem::path& results);

/// Commits when the scope ends normally, rolls back when an exception leaves it.
class ExclusiveTransaction {
 public:
  explicit ExclusiveTransaction(SqlConnection& c) : c_(c) { c_.begin_exclusive(); }
  void commit() {
    c_.commit();
    open_ = false;
  }
  ~ExclusiveTransaction() {
    if (open_) try {
        c_.rollback();
      } catch (...) {
      }
  }
  ExclusiveTransaction(const ExclusiveTransaction&) = delete;
  ExclusiveTransaction& operator=(const ExclusiveTransaction&) = delete;

 private:
  SqlConnection& c_;
  bool open_ = true;
};

}  // namespace insalign::fleet
