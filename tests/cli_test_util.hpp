// Helpers of the tests that write scratch folders, run the insalign command line or expect an
// InputError.
#pragma once

#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <string>
#include <system_error>
#include <utility>

#include "core/errors.hpp"

namespace insalign::testing {

/// An empty folder of its own under the temp directory: prefix, tag and this process's id.
inline std::filesystem::path fresh_dir(const std::string& prefix, const std::string& tag) {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / (prefix + tag + "_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

/// fresh_dir's folder, removed with all in it when this goes out of scope: the suite leaves
/// nothing behind in the temp directory. INSALIGN_KEEP_TEST_DIRS (any value) keeps it, to look
/// at after a failure.
class ScratchDir {
 public:
  ScratchDir(const std::string& prefix, const std::string& tag) : path_(fresh_dir(prefix, tag)) {}
  ScratchDir(const ScratchDir&) = delete;
  ScratchDir& operator=(const ScratchDir&) = delete;
  ~ScratchDir() {
    if (std::getenv("INSALIGN_KEEP_TEST_DIRS") != nullptr) return;
    std::error_code ec;  // never throws: a folder that cannot be removed is left, not a crash
    std::filesystem::remove_all(path_, ec);
  }
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
};

/// Exit code (-1: did not exit) and stdout + stderr of a shell command.
inline std::pair<int, std::string> run_command(const std::string& cmd) {
  FILE* pipe = ::popen((cmd + " 2>&1").c_str(), "r");
  if (pipe == nullptr) return {-1, "popen failed"};
  std::string out;
  char buf[4096];
  while (const std::size_t n = std::fread(buf, 1, sizeof buf, pipe)) out.append(buf, n);
  const int status = ::pclose(pipe);
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, out};
}

struct RunResult {
  int exit_code = -1;  ///< -1: did not exit
  std::string output;  ///< stdout + stderr
};
#ifdef INSALIGN_EXE
/// The insalign command line with these arguments.
inline RunResult run_insalign(const std::string& args) {
  auto [code, out] = run_command(std::string(INSALIGN_EXE) + " " + args);
  return {code, std::move(out)};
}
#endif

/// The message of the InputError that f throws, or "(no InputError)".
inline std::string input_error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  return "(no InputError)";
}

inline bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

}  // namespace insalign::testing
