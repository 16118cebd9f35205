#include "fleet/status.hpp"

#include <chrono>
#include <ctime>
#include <nlohmann/json.hpp>

#include "core/errors.hpp"
#include "files/atomic_file.hpp"
#include "files/read_file.hpp"

namespace insalign::fleet {
namespace {
namespace fs = std::filesystem;
using nlohmann::json;
}  // namespace

fs::path row_dir(const fs::path& results, const ManifestRow& row) { return results / row.car / (row.date + "-" + row.kind); }

fs::path status_path(const fs::path& results, const ManifestRow& row) {
  return results / row.car / (row.date + "-" + row.kind + ".status.json");
}

std::string status_to_json(const TaskStatus& s) {
  const ManifestRow& r = s.row;
  json j = {{"id", s.id},
            {"exit_code", s.exit_code},
            {"error", s.error},
            {"attempts", s.attempts},
            {"host", s.host},
            {"started", s.started},
            {"ended", s.ended},
            {"row", {{"car", r.car}, {"date", r.date}, {"kind", r.kind}, {"input", r.input},
                     {"extrinsic", r.extrinsic}, {"options", r.options}, {"line", r.line}}}};
  return j.dump(2) + "\n";
}

TaskStatus status_from_json(const std::string& text, const std::string& file) {
  try {
    const json j = json::parse(text);
    TaskStatus s;
    s.id = j.at("id").get<std::string>();
    s.exit_code = j.at("exit_code").get<int>();
    s.error = j.at("error").get<std::string>();
    s.attempts = j.at("attempts").get<int>();
    s.host = j.at("host").get<std::string>();
    s.started = j.at("started").get<std::string>();
    s.ended = j.at("ended").get<std::string>();
    if (j.contains("row")) {
      const json& r = j.at("row");
      s.row = {r.at("car").get<std::string>(), r.at("date").get<std::string>(), r.at("kind").get<std::string>(),
               r.at("input").get<std::string>(), r.at("extrinsic").get<std::string>(), r.at("options").get<std::string>(),
               r.value("line", 0)};
    }
    return s;
  } catch (const json::exception& e) {
    throw InputError(file, "", std::string("not a fleet status record: ") + e.what());
  }
}

std::optional<TaskStatus> read_status(const fs::path& results, const ManifestRow& row) {
  const fs::path path = status_path(results, row);
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) return std::nullopt;
  try {
    return status_from_json(io::read_file(path), path.string());
  } catch (const InputError&) {
    return std::nullopt;
  }
}

void write_status(const fs::path& results, const TaskStatus& s) {
  fs::create_directories(status_path(results, s.row).parent_path());
  io::write_file_atomic(status_path(results, s.row), status_to_json(s));
}

bool is_done(const fs::path& results, const ManifestRow& row) {
  const std::optional<TaskStatus> s = read_status(results, row);
  return s && s->id == row.id() && is_done_exit_code(s->exit_code);
}

std::string utc_now() {
  const auto now = std::chrono::system_clock::now();
  const std::time_t t = std::chrono::system_clock::to_time_t(now);
  const auto ms = std::chrono::duration_cast<std::chrono::milliseconds>(now.time_since_epoch()).count() % 1000;
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[40];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%S", &tm);
  char out[48];
  std::snprintf(out, sizeof out, "%s.%03dZ", buf, static_cast<int>(ms));
  return out;
}

}  // namespace insalign::fleet
