// The decode-everything floor (issue 19): every sweep of a drive read and decoded once, one after
// the other on one thread, through the same PCD reader calibrate uses. The method needs only a
// fraction of the sweeps, so a whole calibration should cost a small multiple of this at most;
// bench/table1.sh prints calibrate's time as a ratio to it, measured in the same run.
//
// With --bag, the same for a recording: every PointCloud2 message of its (first) LiDAR topic read
// once (its chunk decompressed once) and decoded: the floor of a run on a recording, e.g. a ROS 1
// bz2 bag, where bzip2 decoding alone may exceed a whole run on the PCD folder.
//
//   build/bench/io_floor --lidar-dir DRIVE/lidar [--repeat 1] [--json]
//   build/bench/io_floor --bag DRIVE.bag [--repeat 1] [--json]
#include <CLI/CLI.hpp>
#include <fmt/core.h>

#include <algorithm>
#include <chrono>
#include <ctime>
#include <filesystem>
#include <memory>
#include <vector>

#include "pointcloud/pcd.hpp"
#include "recording/bag_reader.hpp"
#include "recording/pointcloud2.hpp"

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

// One timed pass: decode(k) for every k < n, returning the points of sweep k.
template <typename Decode>
Pass timed_pass(std::size_t n, Decode decode) {
  Pass pass;
  const auto start = std::chrono::steady_clock::now();
  const double cpu0 = thread_cpu_s();
  for (std::size_t k = 0; k < n; ++k) pass.points += decode(k);
  pass.cpu_s = thread_cpu_s() - cpu0;
  pass.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return pass;
}

// The clouds of a recording's first PointCloud2 topic, each read and decoded once.
struct BagClouds {
  std::unique_ptr<insalign::io::bag::BagReader> reader;
  std::uint32_t topic = 0;
  std::vector<insalign::io::bag::MessageRef> refs;
  explicit BagClouds(const std::filesystem::path& path) : reader(insalign::io::bag::open_bag(path)) {
    for (std::uint32_t t = 0; t < reader->topics().size(); ++t) {
      if (insalign::io::bag::normalized_type(reader->topics()[t].type) != "sensor_msgs/PointCloud2") continue;
      topic = t;
      refs = reader->messages(t);
      return;
    }
  }
  std::size_t decode(std::size_t k) const {
    const auto message = reader->read_shared(refs[k]);
    return insalign::io::bag::decode_sweep(message.bytes, reader->topics()[topic].encoding, "io_floor").size();
  }
};

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Decode every sweep of a drive once, single-threaded: the floor calibrate is compared with"};
  std::string lidar_dir, bag;
  int repeat = 1;
  bool json = false;
  auto* dir_option = app.add_option("--lidar-dir", lidar_dir, "folder of PCD sweeps");
  app.add_option("--bag", bag, "a recording (ROS 1 bag, MCAP, rosbag2) instead: its PointCloud2 messages")
      ->excludes(dir_option);
  app.add_option("--repeat", repeat, "passes over the folder; the fastest is reported")->check(CLI::Range(1, 100));
  app.add_flag("--json", json, "one JSON line instead of text");
  CLI11_PARSE(app, argc, argv);

  if (lidar_dir.empty() == bag.empty()) {
    fmt::print(stderr, "io_floor: give --lidar-dir or --bag\n");
    return 2;
  }
  std::vector<std::filesystem::path> files;
  std::uintmax_t bytes = 0;
  std::unique_ptr<BagClouds> clouds;
  if (!bag.empty()) {
    clouds = std::make_unique<BagClouds>(bag);
    bytes = std::filesystem::is_directory(bag) ? 0 : std::filesystem::file_size(bag);
  } else {
    for (const auto& entry : std::filesystem::directory_iterator(lidar_dir)) {
      if (entry.path().extension() != ".pcd") continue;
      files.push_back(entry.path());
      bytes += entry.file_size();
    }
    std::sort(files.begin(), files.end());
  }
  const std::size_t sweeps = clouds ? clouds->refs.size() : files.size();
  if (sweeps == 0) {
    fmt::print(stderr, "io_floor: no sweeps in {}\n", clouds ? bag : lidar_dir);
    return 2;
  }
  Pass best;
  best.wall_s = 1e300;
  for (int r = 0; r < repeat; ++r) {
    const Pass pass = timed_pass(sweeps, [&](std::size_t k) {
      return clouds ? clouds->decode(k) : insalign::io::read_pcd(files[k]).size();
    });
    if (pass.wall_s < best.wall_s) best = pass;
  }
  const double n = static_cast<double>(sweeps);
  if (json) {
    fmt::print(R"({{"sweeps": {}, "points": {}, "file_mb": {:.1f}, "wall_s": {:.3f}, "cpu_s": {:.3f}}})"
               "\n",
               sweeps, best.points, 1e-6 * static_cast<double>(bytes), best.wall_s, best.cpu_s);
  } else {
    fmt::print("io_floor: {} sweeps, {:.1f} M points, {:.0f} MB of input decoded in {:.2f} s wall ({:.2f} s CPU, one thread):"
               " {:.2f} ms per sweep, {:.0f} MB/s\n",
               sweeps, 1e-6 * static_cast<double>(best.points), 1e-6 * static_cast<double>(bytes), best.wall_s,
               best.cpu_s, 1e3 * best.wall_s / n, 1e-6 * static_cast<double>(bytes) / best.wall_s);
  }
  return 0;
}
