#include "fleet/task.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <atomic>
#include <csignal>
#include <cstring>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include "fleet/process.hpp"
#include "files/atomic_file.hpp"

namespace insalign::fleet {
namespace {

namespace fs = std::filesystem;

std::atomic<int> g_signal{0};
std::atomic<pid_t> g_child{0};

// Stop the row's command with the signal; the task then cleans up and records it.
extern "C" void on_stop_signal(int sig) {
  g_signal = sig;
  const pid_t child = g_child.load();
  if (child > 0) ::kill(child, SIGTERM);
}

void install_stop_handlers() {
  struct sigaction sa {};
  sa.sa_handler = on_stop_signal;
  sigemptyset(&sa.sa_mask);
  for (int sig : {SIGTERM, SIGINT, SIGHUP}) ::sigaction(sig, &sa, nullptr);
}

std::string row_stem(const ManifestRow& row) { return row.date + "-" + row.kind; }

// A lock per row, so that two tasks never run one row at once (a requeued array task whose first
// copy still runs, two `fleet run`s of one manifest). Held until the process ends.
bool lock_row(const fs::path& results, const ManifestRow& row) {
  const fs::path lock = results / row.car / ("." + row_stem(row) + ".lock");
  const int fd = ::open(lock.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  if (fd < 0) return true;  // a file system without locks: run anyway
  return ::flock(fd, LOCK_EX | LOCK_NB) == 0;
}

// The attempt counter lives beside the status: a killed task never writes its status, so the
// next attempt still counts it.
int next_attempt(const fs::path& results, const ManifestRow& row) {
  const fs::path counter = results / row.car / ("." + row_stem(row) + ".attempts");
  int attempts = 0;
  std::ifstream(counter) >> attempts;
  ++attempts;
  io::write_file_atomic(counter, std::to_string(attempts) + "\n");
  return attempts;
}

// Temporary folders of attempts that were killed before they could clean up.
void remove_stale_temporaries(const fs::path& car_dir, const ManifestRow& row) {
  const std::string prefix = "." + row_stem(row) + ".tmp-";
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(car_dir, ec))
    if (entry.path().filename().string().rfind(prefix, 0) == 0) fs::remove_all(entry.path(), ec);
}

// The command's reason for failing: its last "error:" line, else its last line.
std::string error_from_log(const fs::path& log) {
  std::ifstream in(log);
  std::string line, last, last_error;
  while (std::getline(in, line)) {
    if (line.empty()) continue;
    last = line;
    if (line.rfind("error:", 0) == 0 || line.rfind("cannot calibrate:", 0) == 0 || line.rfind("cannot check:", 0) == 0)
      last_error = line;
  }
  return last_error.empty() ? last : last_error;
}

std::string describe_exit(int exit_code) {
  if (exit_code == 127) return "the command could not be started";
  if (exit_code > 128) {
    const int sig = exit_code - 128;
    if (sig == SIGTERM) return "terminated by SIGTERM (scancel, time limit, node shutdown or eviction)";
    if (sig == SIGKILL) return "killed by SIGKILL (out of memory or time limit)";
    return std::string("ended by signal ") + ::strsignal(sig);
  }
  return "exit code " + std::to_string(exit_code);
}

// Moves the finished temporary folder into place; the old result (with --force) goes last.
void publish(const fs::path& tmp, const fs::path& final_dir) {
  const fs::path old = final_dir.string() + ".old-" + std::to_string(::getpid());
  std::error_code ec;
  if (fs::exists(final_dir)) fs::rename(final_dir, old);
  fs::rename(tmp, final_dir);
  fs::remove_all(old, ec);
}

int run_row_command(const Manifest& m, const ManifestRow& row, const fs::path& exe, const fs::path& tmp) {
  ProcessSpec spec{row_command(m, row, exe, tmp), m.folder, tmp / "fleet-task.log", true};
  g_signal = 0;
  install_stop_handlers();
  const pid_t pid = spawn(spec);
  g_child = pid;
  if (g_signal != 0) ::kill(pid, SIGTERM);  // a signal that came before the child's pid was known
  const int exit_code = wait_exit_code(pid);
  g_child = 0;
  return g_signal != 0 ? 128 + g_signal.load() : exit_code;
}

}  // namespace

std::vector<std::string> row_command(const Manifest& m, const ManifestRow& row, const fs::path& exe, const fs::path& out_dir) {
  const std::string where = m.file.string();
  const std::string at = "line " + std::to_string(row.line);
  std::vector<std::string> argv{exe.string(), row.kind};
  for (std::string& w : split_words(row.input, where, at)) argv.push_back(std::move(w));
  if (row.kind == "check") {
    for (std::string& w : split_words(row.extrinsic, where, at)) {
      argv.push_back("--extrinsic");
      argv.push_back(std::move(w));
    }
  }
  for (std::string& w : split_words(row.options, where, at)) argv.push_back(std::move(w));
  argv.push_back("--out");
  argv.push_back(out_dir.string());
  return argv;
}

TaskOutcome run_task(const Manifest& m, std::size_t index, const fs::path& results, const TaskOptions& options) {
  const ManifestRow& row = m.rows.at(index);
  TaskOutcome outcome;
  if (!options.force && is_done(results, row)) {
    outcome.skipped = true;
    outcome.skip_reason = "done already";
    outcome.status = *read_status(results, row);
    return outcome;
  }
  const fs::path car_dir = results / row.car;
  io::ensure_writable_dir(car_dir);
  if (!lock_row(results, row)) {
    outcome.skipped = true;
    outcome.skip_reason = "another task is running this row";
    return outcome;
  }
  remove_stale_temporaries(car_dir, row);
  TaskStatus& s = outcome.status;
  s.id = row.id();
  s.row = row;
  s.host = host_name();
  s.attempts = next_attempt(results, row);
  s.started = utc_now();
  const fs::path tmp = car_dir / ("." + row_stem(row) + ".tmp-" + s.host + "-" + std::to_string(::getpid()));
  fs::create_directories(tmp);
  const fs::path exe = options.exe.empty() ? self_exe() : options.exe;
  try {
    s.exit_code = run_row_command(m, row, exe, tmp);
  } catch (const std::exception& e) {
    s.exit_code = 1;
    s.error = e.what();
  }
  const fs::path final_dir = row_dir(results, row);
  const fs::path log_copy = car_dir / (row_stem(row) + ".log");
  std::error_code ec;
  fs::remove(log_copy, ec);
  if (is_done_exit_code(s.exit_code) && s.exit_code != 0) s.error = error_from_log(tmp / "fleet-task.log");
  if (!is_done_exit_code(s.exit_code) && s.error.empty()) {
    const std::string said = s.exit_code > 128 ? "" : error_from_log(tmp / "fleet-task.log");
    s.error = describe_exit(s.exit_code) + (said.empty() ? "" : ": " + said);
  }
  if (is_done_exit_code(s.exit_code)) {
    publish(tmp, final_dir);
  } else {
    // A failed row keeps its log beside the status and no outputs: nothing half-written stays.
    fs::rename(tmp / "fleet-task.log", log_copy, ec);
    fs::remove_all(tmp, ec);
    fs::remove_all(final_dir, ec);
  }
  s.ended = utc_now();
  write_status(results, s);
  return outcome;
}

long index_from_environment() {
  for (const char* name : {"SLURM_ARRAY_TASK_ID", "JOB_COMPLETION_INDEX"}) {
    const char* v = std::getenv(name);
    if (v == nullptr || *v == '\0') continue;
    char* end = nullptr;
    const long i = std::strtol(v, &end, 10);
    if (end != nullptr && *end == '\0' && i >= 0) return i;
  }
  return -1;
}

}  // namespace insalign::fleet
