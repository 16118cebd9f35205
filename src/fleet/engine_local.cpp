#include "fleet/engine_local.hpp"

#include <sys/wait.h>

#include <cerrno>
#include <set>

#include "fleet/process.hpp"
#include "fleet/rows.hpp"

namespace insalign::fleet {

std::vector<std::string> task_command(const std::filesystem::path& exe, const Manifest& m,
                                      const std::filesystem::path& results, bool force) {
  std::vector<std::string> argv{exe.string(), "fleet", "task", m.file.string(), "--results",
                                std::filesystem::absolute(results).lexically_normal().string()};
  if (force) argv.push_back("--force");
  return argv;
}

void run_local(const Manifest& m, const std::filesystem::path& results, const LocalConfig& config) {
  const std::filesystem::path exe = config.exe.empty() ? self_exe() : config.exe;
  const std::vector<std::size_t> todo = rows_to_run(m, results, config.force);
  const std::size_t jobs = std::max<std::size_t>(1, config.jobs);
  std::set<pid_t> running;
  std::size_t next = 0;
  while (next < todo.size() || !running.empty()) {
    while (next < todo.size() && running.size() < jobs) {
      std::vector<std::string> argv = task_command(exe, m, results, config.force);
      argv.push_back("--index");
      argv.push_back(std::to_string(todo[next++]));
      running.insert(spawn({argv, {}, {}}));
    }
    int status = 0;
    const pid_t done = ::waitpid(-1, &status, 0);
    if (done > 0) running.erase(done);
    else if (errno == ECHILD) running.clear();
  }
}

}  // namespace insalign::fleet
