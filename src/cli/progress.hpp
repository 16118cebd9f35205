// Terminal feedback for long steps: a progress bar with an ETA per step, redrawn in place on a
// terminal; in a file or CI log one line per finished step, plus a progress line for a long step
// at most every 5 s and 10 % (never a carriage return).
// --quiet prints nothing; --verbose adds detail lines. Thread-safe: pipeline stages may report
// from worker threads.
#pragma once

#include <chrono>
#include <cstdio>
#include <functional>
#include <mutex>
#include <string>
#include <string_view>
#include <vector>

namespace insalign::cli {

enum class Verbosity { kQuiet, kNormal, kVerbose };

class ProgressBar {
 public:
  /// is_terminal: redraw in place; by default, whether `out` is a terminal.
  explicit ProgressBar(Verbosity verbosity, std::FILE* out = stderr);
  ProgressBar(Verbosity verbosity, std::FILE* out, bool is_terminal);
  ~ProgressBar();  ///< finishes the step in progress
  ProgressBar(const ProgressBar&) = delete;
  ProgressBar& operator=(const ProgressBar&) = delete;

  /// fraction of `step` done, in [0, 1]. A new step name finishes the previous step.
  void update(std::string_view step, double fraction);
  /// Ends the current step's line ("rough  done in 12.3 s").
  void finish();
  /// A message line (not in quiet mode), printed above the bar.
  void log(std::string_view message);
  /// A detail line, only in verbose mode.
  void detail(std::string_view message);
  /// An adapter for PipelineProgress-style callbacks (step, fraction).
  std::function<void(std::string_view, double)> callback();
  /// Logs (not a terminal, normal verbosity): the least time between two progress lines of a step
  /// (default 5 s; they also need 10 % more done).
  void set_log_interval(std::chrono::milliseconds interval);

  /// The line drawn for a step at `fraction` after `elapsed_s` (exposed for tests).
  static std::string bar_line(std::string_view step, double fraction, double elapsed_s, int width = 30);

 private:
  void finish_locked();
  void print_line_locked(const std::string& line);

  Verbosity verbosity_;
  std::FILE* out_;
  bool tty_;
  std::mutex mutex_;
  std::string step_;
  double fraction_ = 0.0;
  std::chrono::steady_clock::time_point step_start_, last_draw_;
  double step_start_cpu_s_ = 0.0;  ///< process CPU time when the step began
  bool line_open_ = false;  ///< a bar is drawn on the current terminal line
  int next_verbose_decile_ = 1;
  std::chrono::milliseconds log_interval_{5000};
  std::chrono::steady_clock::time_point last_log_;  ///< last progress line in a log
  double last_logged_fraction_ = 0.0;
};

/// "0:07", "1:05", "1:02:03" (h:mm:ss above an hour).
std::string format_duration(double seconds);

/// Columns aligned with two spaces between them; the header underlined with dashes. Cells that
/// look like numbers are right-aligned.
std::string text_table(const std::vector<std::string>& header, const std::vector<std::vector<std::string>>& rows);

}  // namespace insalign::cli
