#include "sim/export/pcd_dataset.hpp"

#include <fmt/core.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <atomic>
#include <thread>
#include <utility>

#include "files/atomic_file.hpp"
#include "files/extrinsic_json.hpp"
#include "files/fiducials.hpp"
#include "files/poses.hpp"

namespace insalign::cli {

namespace fs = std::filesystem;

std::uintmax_t directory_bytes(const fs::path& dir) {
  std::uintmax_t total = 0;
  for (const auto& e : fs::recursive_directory_iterator(dir))
    if (e.is_regular_file()) total += e.file_size();
  return total;
}

bool is_rig(const sim::World& w) { return !w.config.rig.empty(); }

std::vector<fs::path> lidar_dirs(const sim::World& w, const fs::path& out) {
  if (!is_rig(w)) return {out / "lidar"};
  std::vector<fs::path> dirs;
  for (const sim::SimLidar& l : w.lidars) dirs.push_back(out / "lidar" / l.name);
  return dirs;
}

bool prepare_dirs(const std::vector<fs::path>& dirs, bool overwrite) {
  for (const fs::path& dir : dirs) {
    io::ensure_writable_dir(dir);
    std::size_t stale = 0;
    for (const auto& e : fs::directory_iterator(dir)) stale += e.path().extension() == ".pcd";
    if (stale > 0 && !overwrite) {
      fmt::print(stderr, "error: {} already holds {} PCD files; use an empty --out or pass --overwrite\n", dir.string(), stale);
      return false;
    }
    for (const auto& e : fs::directory_iterator(dir))
      if (e.path().extension() == ".pcd") fs::remove(e.path());
  }
  return true;
}

// Every frame of every LiDAR in parallel (each also casts its rays in parallel), written as it
// is rendered: one sweep per worker in memory.
Rendered render_all(const sim::World& w, const std::vector<fs::path>& dirs, io::PcdEncoding encoding, const SimPcdProgress& progress) {
  Rendered r;
  std::vector<std::pair<std::size_t, std::size_t>> jobs;  // (lidar, frame)
  for (std::size_t i = 0; i < w.lidars.size(); ++i) {
    const std::size_t n = w.lidars[i].frame_times_s.size();
    r.t_end_s.emplace_back(n);
    r.names.emplace_back(n);
    for (std::size_t k = 0; k < n; ++k) jobs.emplace_back(i, k);
  }
  std::vector<std::atomic<std::size_t>> points(w.lidars.size());
  const std::size_t n = jobs.size();
  std::atomic<std::size_t> done{0};
  // More workers than cores: a worker blocked in the atomic write's fsync leaves its core to
  // another that is ray casting. TBB caps its workers at the core count unless told otherwise.
  const int threads = static_cast<int>(3 * std::max(1u, std::thread::hardware_concurrency()));
  const tbb::global_control allow_threads(tbb::global_control::max_allowed_parallelism, threads);
  tbb::task_arena arena(threads);
  arena.execute([&] {
    tbb::parallel_for(std::size_t{0}, n, [&](std::size_t j) {
      const auto [i, k] = jobs[j];
      const Sweep sweep = sim::render_lidar_sweep(w, i, k);
      io::write_pcd(dirs[i] / (sweep.name + ".pcd"), sweep, encoding, io::PcdTimeField::kAbsolute);
      r.t_end_s[i][k] = sweep.t_end_s;
      r.names[i][k] = sweep.name;
      points[i] += sweep.size();
      const std::size_t d = ++done;
      if (progress) progress(d, n);
    });
  });
  for (const auto& p : points) r.points.push_back(p.load());
  return r;
}

void write_metadata(const sim::World& w, const fs::path& out, const Rendered& r, const GroundTruthLabels& labels) {
  for (std::size_t i = 0; i < w.lidars.size(); ++i) {
    const std::string suffix = is_rig(w) ? "-" + w.lidars[i].name : "";
    std::vector<Iso3> T_world_ins;
    for (const StampedPose& p : sim::frame_poses(w, r.t_end_s[i], i)) T_world_ins.push_back(p.T_world_ins);
    io::write_opencalib_poses(out / ("poses" + suffix + ".txt"), r.names[i], T_world_ins);
    io::write_opencalib_extrinsic(out / ("init-extrinsic" + suffix + ".json"), w.lidars[i].T_ins_lidar_init);
  }
  io::write_tum_poses(out / "poses_tum.txt", sim::dense_reported_poses(w, 100.0));
  io::write_fiducials(out / "fiducials.txt", w.fiducials);
  nlohmann::json gt = ground_truth_json(w, r.points.front(), labels);
  if (is_rig(w)) gt["lidars"] = rig_ground_truth_json(w, r.points);
  io::write_file_atomic(out / "ground_truth.json", gt.dump(2) + "\n");
  write_installed_extrinsics(w, out);
}

}  // namespace insalign::cli
