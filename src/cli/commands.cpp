#include "cli/commands.hpp"

#include <fmt/core.h>

#include <exception>

#include "core/errors.hpp"

namespace insalign::cli {

int run_guarded(const std::function<int()>& run) {
  try {
    return run();
  } catch (const InputError& e) {
    fmt::print(stderr, "error: {}\n", e.what());
    return kExitUsage;
  } catch (const UnobservableError& e) {
    fmt::print(stderr, "cannot calibrate: {}\n", e.what());
    return kExitUnobservable;
  } catch (const std::exception& e) {
    fmt::print(stderr, "error: {}\n", e.what());
    return kExitOther;
  }
}

std::vector<Command> all_commands() {
  return {make_simulate_command(), make_calibrate_command(), make_check_command(), make_evaluate_command(), make_info_command(),
          make_stitch_command(), make_config_command(), make_fleet_command()};
}

}  // namespace insalign::cli
