#include "fleet/rows.hpp"

#include <fmt/core.h>

#include "fleet/status.hpp"

namespace insalign::fleet {

std::vector<std::size_t> rows_to_run(const Manifest& m, const std::filesystem::path& results, bool force) {
  std::vector<std::size_t> out;
  for (std::size_t i = 0; i < m.rows.size(); ++i)
    if (force || !is_done(results, m.rows[i])) out.push_back(i);
  return out;
}

std::vector<RowReport> row_reports(const Manifest& m, const std::filesystem::path& results,
                                   const std::map<std::size_t, std::string>& engine_states) {
  std::vector<RowReport> out;
  for (std::size_t i = 0; i < m.rows.size(); ++i) {
    RowReport r;
    r.id = m.rows[i].id();
    const auto s = read_status(results, m.rows[i]);
    const auto engine = engine_states.find(i);
    if (s && s->id == r.id) {
      r.exit_code = s->exit_code;
      r.attempts = s->attempts;
      r.error = s->error;
      r.state = is_done_exit_code(s->exit_code) ? "done" : "failed";
    } else {
      r.state = engine != engine_states.end() ? engine->second : "not run";
    }
    out.push_back(r);
  }
  return out;
}

std::string summarize(const std::vector<RowReport>& reports) {
  std::map<std::string, int> counts;
  for (const RowReport& r : reports) ++counts[r.state];
  std::string text = fmt::format("{} rows:", reports.size());
  const char* sep = " ";
  for (const auto& [state, n] : counts) {
    text += fmt::format("{}{} {}", sep, n, state);
    sep = ", ";
  }
  text += "\n";
  for (const RowReport& r : reports) {
    if (r.state == "done") continue;
    text += fmt::format("  {}: {}{}{}\n", r.id, r.state, r.exit_code >= 0 ? fmt::format(" (exit {})", r.exit_code) : "",
                        r.error.empty() ? "" : ": " + r.error);
  }
  return text;
}

bool all_done(const std::vector<RowReport>& reports) {
  for (const RowReport& r : reports)
    if (r.state != "done") return false;
  return true;
}

}  // namespace insalign::fleet
