#include "cli/progress.hpp"

#include <fmt/format.h>
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>

namespace insalign::cli {
namespace {

// CPU seconds of the whole process so far (every thread, user and system).
double process_cpu_s() {
  struct rusage usage {};
  getrusage(RUSAGE_SELF, &usage);
  const auto seconds = [](const timeval& t) { return static_cast<double>(t.tv_sec) + 1e-6 * t.tv_usec; };
  return seconds(usage.ru_utime) + seconds(usage.ru_stime);
}

}  // namespace

ProgressBar::ProgressBar(Verbosity verbosity, std::FILE* out)
    : ProgressBar(verbosity, out, ::isatty(::fileno(out)) != 0) {}

ProgressBar::ProgressBar(Verbosity verbosity, std::FILE* out, bool is_terminal)
    : verbosity_(verbosity), out_(out), tty_(is_terminal) {}

ProgressBar::~ProgressBar() {
  std::lock_guard lock(mutex_);
  finish_locked();
}

std::string ProgressBar::bar_line(std::string_view step, double fraction, double elapsed_s, int width) {
  const double f = std::clamp(std::isfinite(fraction) ? fraction : 0.0, 0.0, 1.0);
  const int filled = static_cast<int>(std::lround(f * width));
  std::string line = fmt::format("{:<10} [{}{}] {:3.0f}%  {}", step, std::string(filled, '#'),
                                 std::string(width - filled, '-'), 100 * f, format_duration(elapsed_s));
  // ETA once the rate means something (a few percent done).
  if (f >= 0.03 && f < 1.0) line += "  ETA " + format_duration(elapsed_s * (1 - f) / f);
  return line;
}

void ProgressBar::update(std::string_view step, double fraction) {
  if (verbosity_ == Verbosity::kQuiet) return;
  std::lock_guard lock(mutex_);
  const auto now = std::chrono::steady_clock::now();
  if (step != step_) {
    finish_locked();
    step_ = std::string(step);
    step_start_ = now;
    step_start_cpu_s_ = process_cpu_s();
    last_draw_ = now - std::chrono::seconds(1);
    next_verbose_decile_ = 1;
    last_log_ = now;
    last_logged_fraction_ = 0.0;
  }
  fraction_ = std::max(fraction_, fraction);  // workers may report out of order
  const double elapsed = std::chrono::duration<double>(now - step_start_).count();
  if (tty_) {
    if (now - last_draw_ < std::chrono::milliseconds(100) && fraction_ < 1.0) return;  // 10 Hz is plenty
    last_draw_ = now;
    fmt::print(out_, "\r{}\033[K", bar_line(step_, fraction_, elapsed));
    std::fflush(out_);
    line_open_ = true;
  } else if (verbosity_ == Verbosity::kVerbose) {
    // Logs: a line every 10%, not a redraw.
    // One line per decile crossed (a step that jumps to its end prints none: its "done" line follows).
    if (next_verbose_decile_ <= 9 && fraction_ >= next_verbose_decile_ / 10.0) {
      next_verbose_decile_ = static_cast<int>(std::floor(fraction_ * 10.0)) + 1;
      if (fraction_ < 1.0) fmt::print(out_, "{}\n", bar_line(step_, fraction_, elapsed));
    }
  } else if (fraction_ < 1.0 && now - last_log_ >= log_interval_ && fraction_ >= last_logged_fraction_ + 0.1) {
    // Logs of a long step: a line now and then says it is alive, without flooding the log.
    fmt::print(out_, "{}\n", bar_line(step_, fraction_, elapsed));
    std::fflush(out_);
    last_log_ = now;
    last_logged_fraction_ = fraction_;
  }
}

void ProgressBar::finish() {
  std::lock_guard lock(mutex_);
  finish_locked();
}

void ProgressBar::finish_locked() {
  if (step_.empty() || verbosity_ == Verbosity::kQuiet) return;
  const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - step_start_).count();
  std::string line = fmt::format("{:<10} done in {}", step_, format_duration(elapsed));
  // Verbose: where the time went, and how much of it used both cores.
  if (verbosity_ == Verbosity::kVerbose)
    line += fmt::format(" ({:.2f} s wall, {:.2f} s CPU)", elapsed, process_cpu_s() - step_start_cpu_s_);
  if (tty_) {
    fmt::print(out_, "\r{}\033[K\n", line);
  } else {
    fmt::print(out_, "{}\n", line);
  }
  std::fflush(out_);
  line_open_ = false;
  step_.clear();
  fraction_ = 0.0;
}

void ProgressBar::print_line_locked(const std::string& line) {
  if (line_open_) fmt::print(out_, "\r\033[K");  // the bar is redrawn on the next update
  fmt::print(out_, "{}\n", line);
  std::fflush(out_);
  line_open_ = false;
  last_draw_ = {};
}

void ProgressBar::log(std::string_view message) {
  if (verbosity_ == Verbosity::kQuiet) return;
  std::lock_guard lock(mutex_);
  print_line_locked(std::string(message));
}

void ProgressBar::detail(std::string_view message) {
  if (verbosity_ != Verbosity::kVerbose) return;
  std::lock_guard lock(mutex_);
  print_line_locked(std::string(message));
}

void ProgressBar::set_log_interval(std::chrono::milliseconds interval) {
  std::lock_guard lock(mutex_);
  log_interval_ = interval;
}

std::function<void(std::string_view, double)> ProgressBar::callback() {
  return [this](std::string_view step, double fraction) { update(step, fraction); };
}

std::string format_duration(double seconds) {
  if (!std::isfinite(seconds) || seconds < 0) return "?";
  const long s = std::lround(seconds);
  if (s >= 3600) return fmt::format("{}:{:02}:{:02}", s / 3600, (s / 60) % 60, s % 60);
  return fmt::format("{}:{:02}", s / 60, s % 60);
}

std::string text_table(const std::vector<std::string>& header, const std::vector<std::vector<std::string>>& rows) {
  std::vector<std::size_t> width(header.size(), 0);
  auto widen = [&](const std::vector<std::string>& row) {
    for (std::size_t c = 0; c < row.size(); ++c) {
      if (c >= width.size()) width.resize(c + 1, 0);
      width[c] = std::max(width[c], row[c].size());
    }
  };
  widen(header);
  for (const auto& r : rows) widen(r);
  auto numeric = [](const std::string& s) {
    return !s.empty() && s.find_first_not_of("+-0123456789.eE%") == std::string::npos;
  };
  auto line = [&](const std::vector<std::string>& row) {
    std::string out;
    for (std::size_t c = 0; c < width.size(); ++c) {
      const std::string cell = c < row.size() ? row[c] : "";
      if (c > 0) out += "  ";
      out += numeric(cell) ? fmt::format("{:>{}}", cell, width[c]) : fmt::format("{:<{}}", cell, width[c]);
    }
    while (!out.empty() && out.back() == ' ') out.pop_back();
    return out + "\n";
  };
  std::string out = line(header);
  std::size_t total = 0;
  for (std::size_t c = 0; c < width.size(); ++c) total += width[c] + (c > 0 ? 2 : 0);
  out += std::string(total, '-') + "\n";
  for (const auto& r : rows) out += line(r);
  return out;
}

}  // namespace insalign::cli
