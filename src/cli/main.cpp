// insalign command line: parses arguments, calls the library, maps errors to exit codes.
#include <CLI/CLI.hpp>
#include <fmt/core.h>
#include <malloc.h>

#include "cli/commands.hpp"

namespace {

// A calibration allocates and frees sweeps and maps of megabytes all run long. By default glibc
// returns such blocks to the kernel at every free, and every page of the next one costs a page
// fault: on a virtual machine several microseconds, a fifth of a calibration's CPU time
// (bench/RESULTS.md, seventh session). Freed memory is kept for reuse instead; the peak grows
// by about 4%.
void keep_freed_memory() {
#ifdef __GLIBC__
  mallopt(M_MMAP_THRESHOLD, 32 << 20);  // glibc's upper limit; larger blocks are still mapped
  mallopt(M_TRIM_THRESHOLD, 1 << 30);
#endif
}

}  // namespace

int main(int argc, char** argv) {
  keep_freed_memory();
  CLI::App app{"insalign: LiDAR to GNSS/INS extrinsic calibration"};
  app.require_subcommand(1);
  std::vector<insalign::cli::Command> commands = insalign::cli::all_commands();
  std::vector<CLI::App*> subcommands;
  for (auto& command : commands) subcommands.push_back(command.setup(app));
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int rc = app.exit(e);
    return rc == 0 ? 0 : insalign::cli::kExitUsage;
  }
  for (std::size_t i = 0; i < commands.size(); ++i) {
    if (subcommands[i]->parsed()) return insalign::cli::run_guarded(commands[i].run);
  }
  return insalign::cli::kExitOther;
}
