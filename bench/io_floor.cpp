// The decode-everything floor (issue 19): every sweep of a drive read and decoded once, one after
// the other on one thread, through the same PCD reader calibrate uses. The method needs only a
// fraction of the sweeps, so a whole calibration should cost a small multiple of this at most;
// bench/table1.sh prints calibrate's time as a ratio to it, measured in the same run.
//
//   build/bench/io_floor --lidar-dir DRIVE/lidar [--repeat 1] [--json]
#include <CLI/CLI.hpp>
#include <fmt/core.h>

#include <algorithm>
#include <chrono>
#include <ctime>
#include <filesystem>
#include <vector>

#include "pointcloud/pcd.hpp"

namespace {

double thread_cpu_s() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

struct Pass {
  double wall_s = 0.0, cpu_s = 0.0;
  std::size_t points = 0;
};

Pass decode_all(const std::vector<std::filesystem::path>& files) {
  Pass pass;
  const auto start = std::chrono::steady_clock::now();
  const double cpu0 = thread_cpu_s();
  for (const auto& path : files) pass.points += insalign::io::read_pcd(path).size();
  pass.cpu_s = thread_cpu_s() - cpu0;
  pass.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return pass;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Decode every sweep of a drive once, single-threaded: the floor calibrate is compared with"};
  std::string lidar_dir;
  int repeat = 1;
  bool json = false;
  app.add_option("--lidar-dir", lidar_dir, "folder of PCD sweeps")->required();
  app.add_option("--repeat", repeat, "passes over the folder; the fastest is reported")->check(CLI::Range(1, 100));
  app.add_flag("--json", json, "one JSON line instead of text");
  CLI11_PARSE(app, argc, argv);

  std::vector<std::filesystem::path> files;
  std::uintmax_t bytes = 0;
  for (const auto& entry : std::filesystem::directory_iterator(lidar_dir)) {
    if (entry.path().extension() != ".pcd") continue;
    files.push_back(entry.path());
    bytes += entry.file_size();
  }
  std::sort(files.begin(), files.end());
  if (files.empty()) {
    fmt::print(stderr, "io_floor: no .pcd files in {}\n", lidar_dir);
    return 2;
  }
  Pass best;
  best.wall_s = 1e300;
  for (int r = 0; r < repeat; ++r) {
    const Pass pass = decode_all(files);
    if (pass.wall_s < best.wall_s) best = pass;
  }
  const double n = static_cast<double>(files.size());
  if (json) {
    fmt::print(R"({{"sweeps": {}, "points": {}, "file_mb": {:.1f}, "wall_s": {:.3f}, "cpu_s": {:.3f}}})"
               "\n",
               files.size(), best.points, 1e-6 * static_cast<double>(bytes), best.wall_s, best.cpu_s);
  } else {
    fmt::print("io_floor: {} sweeps, {:.1f} M points, {:.0f} MB of PCD decoded in {:.2f} s wall ({:.2f} s CPU, one thread):"
               " {:.2f} ms per sweep, {:.0f} MB/s\n",
               files.size(), 1e-6 * static_cast<double>(best.points), 1e-6 * static_cast<double>(bytes), best.wall_s,
               best.cpu_s, 1e3 * best.wall_s / n, 1e-6 * static_cast<double>(bytes) / best.wall_s);
  }
  return 0;
}
