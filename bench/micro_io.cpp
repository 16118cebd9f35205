// Google Benchmark micro-benchmarks of PCD reading and writing: one simulated Pandar64 sweep at
// 0.2 deg (about 100k returns of 115k beams) with intensity, ring and an absolute double
// timestamp, as `insalign simulate` writes it, in each DATA encoding. read_pcd takes a path, so
// the files sit in a temporary directory (in the page cache after the first read: this measures
// decoding, not the disk). Bytes are the file's size; items are points; rates use wall time.
//
//   build-micro/bench/micro_io --benchmark_min_time=0.5
#include <benchmark/benchmark.h>

#include <cstdint>
#include <filesystem>
#include <string>
#include <system_error>
#include <unistd.h>

#include "pointcloud/pcd.hpp"
#include "sim/simulate.hpp"

namespace insalign {
namespace {

namespace fs = std::filesystem;

/// A cruising frame of a short figure-8 drive (the start ramp lasts 3 s).
const Sweep& sweep() {
  static const Sweep s = [] {
    sim::SimConfig config;
    config.seed = 1;
    config.lidar_model = "pandar64";
    config.duration_s = 4.0;
    const sim::World world = sim::build_world(config);
    return sim::render_sweep(world, world.frame_count() - 1);
  }();
  return s;
}

/// Removes the temporary directory when the program ends.
struct TempDir {
  fs::path path = fs::temp_directory_path() / ("insalign-micro-io-" + std::to_string(::getpid()));
  TempDir() { fs::create_directories(path); }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path, ec);
  }
};
const fs::path& temp_dir() {
  static const TempDir dir;
  return dir.path;
}

const char* label_of(io::PcdEncoding e) {
  switch (e) {
    case io::PcdEncoding::kAscii: return "ascii";
    case io::PcdEncoding::kBinary: return "binary";
    case io::PcdEncoding::kBinaryCompressed: return "binary_compressed";
  }
  return "?";
}

/// The sweep written once per encoding.
fs::path sweep_file(io::PcdEncoding encoding) {
  const fs::path path = temp_dir() / (std::string(label_of(encoding)) + ".pcd");
  if (!fs::exists(path)) io::write_pcd(path, sweep(), encoding, io::PcdTimeField::kAbsolute);
  return path;
}

void BM_ReadPcd(benchmark::State& state, io::PcdEncoding encoding) {
  const fs::path path = sweep_file(encoding);
  const auto bytes = static_cast<std::int64_t>(fs::file_size(path));
  std::size_t points = 0;
  for (auto _ : state) {
    const Sweep s = io::read_pcd(path);
    points = s.size();
    benchmark::DoNotOptimize(s.p_lidar.data());
  }
  state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations()) * bytes);
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations()) * static_cast<std::int64_t>(points));
  state.counters["file_MB"] = static_cast<double>(bytes) / 1e6;
  state.counters["points"] = static_cast<double>(points);
}
BENCHMARK_CAPTURE(BM_ReadPcd, ascii, io::PcdEncoding::kAscii)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK_CAPTURE(BM_ReadPcd, binary, io::PcdEncoding::kBinary)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK_CAPTURE(BM_ReadPcd, binary_compressed, io::PcdEncoding::kBinaryCompressed)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

// Writing includes write_pcd's atomic rename and fsync, so it depends on the file system too.
void BM_WritePcd(benchmark::State& state, io::PcdEncoding encoding) {
  const fs::path path = temp_dir() / (std::string("write-") + label_of(encoding) + ".pcd");
  for (auto _ : state) io::write_pcd(path, sweep(), encoding, io::PcdTimeField::kAbsolute);
  const auto bytes = static_cast<std::int64_t>(fs::file_size(path));
  state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations()) * bytes);
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations()) * static_cast<std::int64_t>(sweep().size()));
  state.counters["file_MB"] = static_cast<double>(bytes) / 1e6;
}
BENCHMARK_CAPTURE(BM_WritePcd, ascii, io::PcdEncoding::kAscii)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK_CAPTURE(BM_WritePcd, binary, io::PcdEncoding::kBinary)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK_CAPTURE(BM_WritePcd, binary_compressed, io::PcdEncoding::kBinaryCompressed)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

}  // namespace
}  // namespace insalign

BENCHMARK_MAIN();
