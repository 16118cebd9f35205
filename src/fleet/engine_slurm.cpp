#include "fleet/engine_slurm.hpp"

#include <fmt/core.h>

#include <chrono>
#include <cmath>
#include <sstream>
#include <stdexcept>
#include <thread>

#include "fleet/engine_local.hpp"
#include "fleet/process.hpp"
#include "fleet/rows.hpp"
#include "files/atomic_file.hpp"

namespace insalign::fleet {
namespace {

namespace fs = std::filesystem;

std::uintmax_t path_bytes(const fs::path& p) {
  std::error_code ec;
  if (fs::is_regular_file(p, ec)) return fs::file_size(p, ec);
  std::uintmax_t total = 0;
  if (fs::is_directory(p, ec))
    for (const auto& e : fs::recursive_directory_iterator(p, ec))
      if (e.is_regular_file(ec)) total += e.file_size(ec);
  return total;
}

// Single quotes for the shell: the script names paths with any characters.
std::string shell_quote(const std::string& s) {
  std::string out = "'";
  for (char c : s) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

std::string shell_command(const std::vector<std::string>& argv) {
  std::string out;
  for (const std::string& a : argv) out += (out.empty() ? "" : " ") + shell_quote(a);
  return out;
}

// squeue lists array tasks as "<job>_<index>"; the index part of each line "<index> <state>".
std::map<std::size_t, std::string> parse_index_states(const std::string& text) {
  std::map<std::size_t, std::string> out;
  std::istringstream in(text);
  std::string index, state;
  while (in >> index >> state) {
    char* end = nullptr;
    const long i = std::strtol(index.c_str(), &end, 10);
    if (end != index.c_str() && *end == '\0' && i >= 0) out[static_cast<std::size_t>(i)] = state;
  }
  return out;
}

// Final states: sacct where accounting is kept, else scontrol (jobs stay there MinJobAge seconds).
std::map<std::size_t, std::string> final_states(const std::string& job_id) {
  const Captured sacct = run_captured({"sacct", "-n", "-X", "-P", "-j", job_id, "-o", "JobID,State"});
  std::map<std::size_t, std::string> out;
  if (sacct.exit_code == 0) {
    std::istringstream in(sacct.output);
    std::string line;
    while (std::getline(in, line)) {
      const std::size_t us = line.find('_'), bar = line.find('|');
      if (us == std::string::npos || bar == std::string::npos || us > bar) continue;
      const std::string state = line.substr(bar + 1, line.find(' ', bar) - bar - 1);  // "CANCELLED by 0"
      const std::string index = line.substr(us + 1, bar - us - 1);
      if (!index.empty() && index.find_first_not_of("0123456789") == std::string::npos) out[std::stoul(index)] = state;
    }
    if (!out.empty()) return out;
  }
  const Captured sc = run_captured({"scontrol", "-o", "show", "job", job_id});
  std::istringstream in(sc.output);
  std::string line;
  while (std::getline(in, line)) {
    const std::size_t a = line.find("ArrayTaskId="), s = line.find("JobState=");
    if (a == std::string::npos || s == std::string::npos) continue;
    const std::string index = line.substr(a + 12, line.find(' ', a) - a - 12);
    if (index.empty() || index.find_first_not_of("0123456789") != std::string::npos) continue;  // "3-7%2": still pending
    out[std::stoul(index)] = line.substr(s + 9, line.find(' ', s) - s - 9);
  }
  return out;
}

}  // namespace

std::uintmax_t recording_bytes(const Manifest& m, const ManifestRow& row) {
  std::uintmax_t total = 0;
  for (const std::string& w : split_words(row.input, m.file.string(), "line " + std::to_string(row.line)))
    if (w.rfind("--", 0) != 0) total += path_bytes(fs::path(w).is_absolute() ? fs::path(w) : m.folder / w);
  return total;
}

std::string array_spec(const std::vector<std::size_t>& indices, std::size_t limit) {
  std::string spec;
  for (std::size_t i = 0; i < indices.size();) {
    std::size_t j = i;
    while (j + 1 < indices.size() && indices[j + 1] == indices[j] + 1) ++j;
    spec += (spec.empty() ? "" : ",") + std::to_string(indices[i]);
    if (j > i) spec += "-" + std::to_string(indices[j]);
    i = j + 1;
  }
  return spec + "%" + std::to_string(std::max<std::size_t>(1, limit));
}

std::string slurm_script(const Manifest& m, const fs::path& results_in, const std::vector<std::size_t>& indices,
                         const SlurmConfig& c) {
  const fs::path results = fs::absolute(results_in).lexically_normal();
  std::uintmax_t largest = 0;
  for (std::size_t i : indices) largest = std::max(largest, recording_bytes(m, m.rows[i]));
  const double gb = static_cast<double>(largest) / 1e9;
  const int minutes = static_cast<int>(std::ceil(c.base_minutes + c.minutes_per_gb * gb));
  const int memory_mb = static_cast<int>(std::ceil(c.base_memory_mb + c.memory_mb_per_gb * gb));
  const fs::path exe = c.exe.empty() ? self_exe() : c.exe;
  std::string s = "#!/bin/bash\n";
  s += fmt::format("# insalign fleet: one array task per manifest row ({} of {} rows; largest recording {:.1f} MB).\n",
                   indices.size(), m.rows.size(), static_cast<double>(largest) / 1e6);
  s += "# Every task runs `insalign fleet task`, which takes its row from SLURM_ARRAY_TASK_ID.\n";
  s += "#SBATCH --job-name=insalign-fleet\n";
  s += "#SBATCH --array=" + array_spec(indices, c.jobs) + "\n";
  s += fmt::format("#SBATCH --time={}\n", minutes);
  s += fmt::format("#SBATCH --mem={}M\n", memory_mb);
  s += fmt::format("#SBATCH --cpus-per-task={}\n", c.cpus_per_task);
  s += "#SBATCH --ntasks=1\n";
  s += "#SBATCH --requeue\n";
  s += "#SBATCH --open-mode=append\n";  // a requeued task's log continues the first attempt's
  s += "#SBATCH --output=" + (results / "slurm" / "logs" / "%A_%a.out").string() + "\n";
  if (!c.partition.empty()) s += "#SBATCH --partition=" + c.partition + "\n";
  for (const std::string& o : c.sbatch_options) s += "#SBATCH " + o + "\n";
  s += "set -eu\n";
  s += "exec " + shell_command(task_command(exe, m, results, c.force)) + "\n";
  return s;
}

std::string submit_slurm(const Manifest& m, const fs::path& results, const SlurmConfig& c) {
  const std::vector<std::size_t> todo = rows_to_run(m, results, c.force);
  if (todo.empty()) return "";
  const fs::path dir = fs::absolute(results) / "slurm";
  fs::create_directories(dir / "logs");
  const fs::path script = dir / "fleet.sbatch";
  io::write_file_atomic(script, slurm_script(m, results, todo, c));
  const Captured out = run_captured({"sbatch", "--parsable", script.string()});
  if (out.exit_code != 0) throw std::runtime_error("sbatch " + script.string() + " failed: " + out.output);
  std::string id = out.output.substr(0, out.output.find_first_of(";\n"));
  return id;
}

std::vector<std::string> slurm_latency_hints(const std::string& show_config) {
  std::map<std::string, std::string> value;  // "Key   = value" lines
  std::istringstream in(show_config);
  for (std::string line; std::getline(in, line);) {
    const std::size_t eq = line.find(" = ");
    if (eq == std::string::npos) continue;
    std::string key = line.substr(0, eq);
    key.erase(key.find_last_not_of(' ') + 1);
    value[key] = line.substr(eq + 3);
  }
  std::vector<std::string> hints;
  const auto epilog = value.find("Epilog");
  if (epilog != value.end() && (epilog->second.empty() || epilog->second == "(null)"))
    hints.push_back("this cluster has no Epilog, so a freed slot waits for slurmctld's next one-second pass before the "
                    "next row starts; `Epilog=/bin/true` in slurm.conf starts it at once");
  const auto sched = value.find("SchedulerParameters");
  if (sched != value.end() && sched->second.find("batch_sched_delay=0") == std::string::npos)
    hints.push_back("slurmctld may delay starting a batch task by up to batch_sched_delay (3 s by default); "
                    "`SchedulerParameters=batch_sched_delay=0` in slurm.conf removes that wait");
  return hints;
}

std::vector<std::string> slurm_latency_hints() {
  const Captured config = run_captured({"scontrol", "show", "config"});
  return config.exit_code == 0 ? slurm_latency_hints(config.output) : std::vector<std::string>{};
}

std::map<std::size_t, std::string> wait_slurm(const Manifest& m, const std::string& job_id, const SlurmConfig& c) {
  std::map<std::size_t, std::string> last;
  for (;;) {
    const Captured q = run_captured({"squeue", "-h", "-r", "-j", job_id, "-o", "%K %T"});
    const std::map<std::size_t, std::string> now = q.exit_code == 0 ? parse_index_states(q.output)
                                                                      : std::map<std::size_t, std::string>{};
    for (const auto& [i, state] : now) {
      if (i >= m.rows.size()) continue;
      const auto it = last.find(i);
      if (it == last.end() || it->second != state) fmt::print("{}: {}\n", m.rows[i].id(), state);
    }
    if (now.empty()) break;
    last = now;
    std::this_thread::sleep_for(std::chrono::duration<double>(c.poll_s));
  }
  std::map<std::size_t, std::string> states = final_states(job_id);
  fmt::print("job {} ended; Slurm's final state per row:\n", job_id);
  for (const auto& [i, state] : states)
    if (i < m.rows.size()) fmt::print("{}: {}\n", m.rows[i].id(), state);
  return states;
}

}  // namespace insalign::fleet
