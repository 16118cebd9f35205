// Small simulated drives and manifests for the fleet's tests (built once per test process).
#pragma once

#include <fcntl.h>
#include <gtest/gtest.h>
#include <sys/file.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include "cli_test_util.hpp"

namespace insalign::testing {

namespace fs = std::filesystem;

/// A tiny drive (VLP-16 at 1 deg, 120 frames of a figure-8: a few seconds to calibrate) with a
/// given true mount "x y z roll pitch yaw".
inline void simulate_drive(const fs::path& dir, int seed, const std::string& mount) {
  if (fs::exists(dir / "ground_truth.json")) return;
  const fs::path tmp = dir.string() + ".tmp-" + std::to_string(::getpid());
  fs::remove_all(tmp);
  const auto [rc, out] = run_command(std::string(INSALIGN_EXE) + " simulate --out " + tmp.string() + " --seed " +
                                     std::to_string(seed) + " --loops 1 --frames 120 --lidar vlp16 --azimuth-step-deg 1 --extrinsic \"" +
                                     mount + "\" --quiet");
  ASSERT_EQ(rc, 0) << out;
  fs::rename(tmp, dir);
}

/// The drives every fleet test shares, in one folder: car A's and car B's mounts, car B after a
/// knock (yaw +3 deg, roll +1.5 deg), and a copy of A whose pose file is corrupt at line 20.
struct FleetDrives {
  fs::path dir;
};

// Shared by the test processes ctest runs at once: the first one simulates, under a lock.
inline const FleetDrives& fleet_drives() {
  static FleetDrives d = [] {
    FleetDrives f{fs::temp_directory_path() / "insalign_fleet_drives_v1"};
    fs::create_directories(f.dir);
    const int lock = ::open((f.dir / ".lock").c_str(), O_RDWR | O_CREAT, 0644);
    ::flock(lock, LOCK_EX);
    simulate_drive(f.dir / "a", 11, "0.5 0.1 1.6 1 2 90");
    simulate_drive(f.dir / "b", 12, "-0.3 0.2 1.8 -1 0.5 180");
    simulate_drive(f.dir / "b-knocked", 13, "-0.3 0.2 1.8 0.5 0.5 183");
    if (!fs::exists(f.dir / "corrupt" / "poses.txt")) {
      fs::remove_all(f.dir / "corrupt");
      fs::remove_all(f.dir / "corrupt.tmp");
      fs::copy(f.dir / "a", f.dir / "corrupt.tmp", fs::copy_options::recursive);
      std::ifstream in(f.dir / "a" / "poses.txt");
      std::ofstream out(f.dir / "corrupt.tmp" / "poses.txt");
      std::string line;
      for (int n = 1; std::getline(in, line); ++n) out << (n == 20 ? std::string("0.1 0.2 not-a-number") : line) << "\n";
      out.close();
      fs::rename(f.dir / "corrupt.tmp", f.dir / "corrupt");
    }
    ::flock(lock, LOCK_UN);
    ::close(lock);
    return f;
  }();
  return d;
}

/// A manifest row for a calibration of one of the shared drives (paths relative to the manifest).
inline std::string calibrate_row(const std::string& car, const std::string& date, const std::string& drive) {
  return car + "," + date + ",calibrate,--lidar-dir " + drive + "/lidar --poses " + drive + "/poses.txt,,\"--init " + drive +
         "/init-extrinsic.json --fiducials " + drive + "/fiducials.txt\"\n";
}

inline fs::path write_manifest(const fs::path& path, const std::string& rows) {
  std::ofstream(path) << "car,date,kind,input,extrinsic,options\n" << rows;
  return path;
}

inline std::string exe() { return INSALIGN_EXE; }

}  // namespace insalign::testing
