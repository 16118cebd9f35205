#include "fleet/ingest.hpp"

#include <algorithm>
#include <nlohmann/json.hpp>

#include "core/errors.hpp"
#include "files/read_file.hpp"

namespace insalign::fleet {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

// extrinsic.json's stddev keys carry their unit.
constexpr std::array<const char*, 7> kStddevKeys{"tx_m", "ty_m", "tz_m", "roll_deg", "pitch_deg", "yaw_deg", "time_offset_s"};

json read_json(const fs::path& path) {
  try {
    return json::parse(io::read_file(path));
  } catch (const json::exception& e) {
    throw InputError(path.string(), "", std::string("not JSON: ") + e.what());
  }
}

std::optional<double> number_at(const json& j, const char* key) {
  if (!j.is_object() || !j.contains(key) || !j.at(key).is_number()) return std::nullopt;
  return j.at(key).get<double>();
}

std::array<double, 16> matrix(const json& j, const fs::path& file) {
  std::array<double, 16> m{};
  if (!j.is_array() || j.size() != 4) throw InputError(file.string(), "", "T_ins_lidar is not a 4x4 array");
  for (int r = 0; r < 4; ++r) {
    if (!j[r].is_array() || j[r].size() != 4) throw InputError(file.string(), "", "T_ins_lidar is not a 4x4 array");
    for (int c = 0; c < 4; ++c) m[static_cast<std::size_t>(4 * r + c)] = j[r][c].get<double>();
  }
  return m;
}

// A calibration's result for one LiDAR (extrinsic.json, or one entry of rig.json's "lidars").
ExtrinsicRecord calibration_record(const json& j, const std::string& run_id, const std::string& lidar, const fs::path& file) {
  ExtrinsicRecord e;
  e.run_id = run_id;
  e.lidar = lidar;
  e.T_ins_lidar = matrix(j.at("T_ins_lidar"), file);
  e.time_offset_s = number_at(j, "time_offset_s");
  const json stddev = j.value("stddev", json::object());
  const json determined = j.value("determined", json::object());
  for (std::size_t i = 0; i < kFleetDofs.size(); ++i) {
    e.stddev[i] = number_at(stddev, kStddevKeys[i]);
    if (determined.contains(kFleetDofs[i]) && determined.at(kFleetDofs[i]).is_boolean())
      e.determined[i] = determined.at(kFleetDofs[i]).get<bool>();
  }
  return e;
}

// A check's result for one LiDAR: the corrected extrinsic and, per DOF, correction and verdict.
ExtrinsicRecord check_record(const json& j, const std::string& run_id, const std::string& lidar, const fs::path& file) {
  ExtrinsicRecord e;
  e.run_id = run_id;
  e.lidar = lidar;
  const json corrected = j.value("corrected", json::object());
  const json& T = corrected.contains("T_ins_lidar") ? corrected.at("T_ins_lidar") : j.at("checked").at("T_ins_lidar");
  e.T_ins_lidar = matrix(T, file);
  e.time_offset_s = number_at(corrected, "time_offset_s");
  const json dofs = j.value("dofs", json::object());
  for (std::size_t i = 0; i < kFleetDofs.size(); ++i) {
    if (!dofs.contains(kFleetDofs[i])) continue;
    const json& d = dofs.at(kFleetDofs[i]);
    e.correction[i] = number_at(d, "correction");
    e.stddev[i] = number_at(d, "stddev");
    e.dof_verdict[i] = d.value("verdict", "");
    e.determined[i] = e.dof_verdict[i] != "not-observable";
  }
  return e;
}

std::string report_page(const fs::path& dir) {
  for (const char* name : {"check.html", "report.html"})
    if (fs::is_regular_file(dir / name)) return (dir / name).string();
  return "";
}

}  // namespace

RunRecord run_from_status(const TaskStatus& s, const fs::path& results) {
  const ManifestRow& row = s.row;
  RunRecord r{s.id, row.car, row.date, row.kind, row.input, s.exit_code, "failed", s.error, s.started, s.ended, s.attempts,
              s.host, ""};
  if (!is_done_exit_code(s.exit_code)) return r;
  const fs::path dir = row_dir(results, row);
  r.report = report_page(dir);
  if (row.kind == "check") {
    r.verdict = fs::is_regular_file(dir / "check.json") ? read_json(dir / "check.json").value("verdict", "inconclusive")
                                                       : (s.exit_code == 4 ? "recalibrate" : s.exit_code == 3 ? "inconclusive" : "ok");
  } else {
    r.verdict = s.exit_code == 0 ? "calibrated" : "not-determined";
  }
  return r;
}

std::vector<ExtrinsicRecord> extrinsics_from_outputs(const TaskStatus& s, const fs::path& results) {
  std::vector<ExtrinsicRecord> out;
  if (!is_done_exit_code(s.exit_code)) return out;
  const fs::path dir = row_dir(results, s.row);
  const bool check = s.row.kind == "check";
  const fs::path file = check ? dir / "check.json" : fs::is_regular_file(dir / "rig.json") ? dir / "rig.json" : dir / "extrinsic.json";
  if (!fs::is_regular_file(file)) return out;  // exit 3 without a result: nothing to store
  const json j = read_json(file);
  try {
    if (j.contains("lidars")) {
      for (const auto& [name, value] : j.at("lidars").items())
        out.push_back(check ? check_record(value, s.id, name, file) : calibration_record(value, s.id, name, file));
    } else if (j.contains("T_ins_lidar") || j.contains("corrected") || j.contains("checked")) {
      out.push_back(check ? check_record(j, s.id, "lidar", file) : calibration_record(j, s.id, "lidar", file));
    }
  } catch (const json::exception& e) {
    throw InputError(file.string(), "", e.what());
  }
  return out;
}

std::vector<fs::path> find_status_files(const fs::path& results) {
  std::vector<fs::path> out;
  std::error_code ec;
  for (const auto& car : fs::directory_iterator(results, ec)) {
    if (!car.is_directory() || car.path().filename().string().front() == '.') continue;
    for (const auto& f : fs::directory_iterator(car.path(), ec)) {
      const std::string name = f.path().filename().string();
      if (name.size() > 12 && name.compare(name.size() - 12, 12, ".status.json") == 0 && name.front() != '.') out.push_back(f.path());
    }
  }
  std::sort(out.begin(), out.end());
  return out;
}

IngestSummary ingest_results(const fs::path& results, SqlConnection& db) {
  if (!fs::is_directory(results)) throw InputError(results.string(), "", "no such results folder");
  migrate(db);
  IngestSummary summary;
  struct Loaded {
    RunRecord run;
    std::vector<ExtrinsicRecord> extrinsics;
  };
  std::vector<Loaded> loaded;  // read before the transaction: the lock is held only to write
  for (const fs::path& file : find_status_files(results)) {
    try {
      const TaskStatus s = status_from_json(io::read_file(file), file.string());
      if (s.row.car.empty()) throw InputError(file.string(), "", "no \"row\" (written by an older insalign?)");
      loaded.push_back({run_from_status(s, results), extrinsics_from_outputs(s, results)});
    } catch (const InputError& e) {
      summary.unreadable.push_back(e.what());
    } catch (const json::exception& e) {  // a check.json of another shape: skipped with the reason, never the ingest
      summary.unreadable.push_back(file.string() + ": " + e.what());
    }
  }
  ExclusiveTransaction tx(db);
  for (const Loaded& l : loaded) {
    switch (store_run(db, l.run, l.extrinsics)) {
      case StoreOutcome::kInserted: ++summary.inserted; break;
      case StoreOutcome::kReplaced: ++summary.replaced; break;
      case StoreOutcome::kUnchanged: ++summary.unchanged; break;
    }
  }
  tx.commit();
  return summary;
}

}  // namespace insalign::fleet
