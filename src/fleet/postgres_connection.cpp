// The PostgreSQL backend, through libpq: a shared history for several machines and ingests.
#include <libpq-fe.h>

#include "fleet/sql_connection.hpp"

namespace insalign::fleet {
namespace {

// Every writer of the fleet's tables takes this lock for its transaction, so that concurrent
// ingests (and migrations) run one after the other instead of racing on the same rows.
constexpr const char* kWriterLock = "SELECT pg_advisory_xact_lock(3939003939)";

class PostgresConnection final : public SqlConnection {
 public:
  explicit PostgresConnection(const std::string& conninfo) : conn_(PQconnectdb(conninfo.c_str())) {
    if (PQstatus(conn_) != CONNECTION_OK) {
      const std::string why = PQerrorMessage(conn_);
      PQfinish(conn_);
      throw DatabaseError("cannot connect to PostgreSQL (" + conninfo + "): " + why);
    }
    query("SET client_min_messages = warning", {});  // no NOTICE lines for IF NOT EXISTS
  }
  ~PostgresConnection() override { PQfinish(conn_); }

  std::string dialect() const override { return "postgresql"; }

  std::vector<SqlRow> query(const std::string& sql, const std::vector<SqlValue>& params) override {
    std::vector<const char*> values;
    for (const SqlValue& p : params) values.push_back(p ? p->c_str() : nullptr);
    PGresult* res = PQexecParams(conn_, sql.c_str(), static_cast<int>(values.size()), nullptr, values.data(), nullptr,
                                 nullptr, 0);
    const ExecStatusType st = PQresultStatus(res);
    if (st != PGRES_COMMAND_OK && st != PGRES_TUPLES_OK) {
      const std::string why = PQresultErrorMessage(res);
      PQclear(res);
      throw DatabaseError("PostgreSQL: " + why + " (in: " + sql.substr(0, 120) + ")");
    }
    std::vector<SqlRow> rows;
    for (int r = 0; r < PQntuples(res); ++r) {
      SqlRow row;
      for (int c = 0; c < PQnfields(res); ++c)
        row.push_back(PQgetisnull(res, r, c) ? SqlValue{} : SqlValue{std::string(PQgetvalue(res, r, c))});
      rows.push_back(std::move(row));
    }
    PQclear(res);
    return rows;
  }

  void begin_exclusive() override {
    query("BEGIN", {});
    query(kWriterLock, {});
  }
  void commit() override { query("COMMIT", {}); }
  void rollback() override { query("ROLLBACK", {}); }

 private:
  PGconn* conn_;
};

}  // namespace

std::unique_ptr<SqlConnection> open_postgres(const std::string& conninfo) { return std::make_unique<PostgresConnection>(conninfo); }

}  // namespace insalign::fleet
