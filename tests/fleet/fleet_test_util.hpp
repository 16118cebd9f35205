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
  if (rc != 0) fs::remove_all(tmp);  // nothing half-made left in the cache
  ASSERT_EQ(rc, 0) << out;
  fs::rename(tmp, dir);
}

/// Every test car's installed mount (m, deg), and the true mount of car B after its knock: yaw
/// +0.6 deg (`--knock "0 0 0 0 0 0.6"`), far beyond the 0.05 deg tolerance, below the 3 deg
/// "wrong file" limit.
inline constexpr const char* kCheckMount = "0.8 -0.2 1.7 0.5 -1 2";
inline constexpr const char* kCheckMountKnocked = "0.8 -0.2 1.7 0.5 -1 2.6";
inline constexpr const char* kCheckKnock = "0 0 0 0 0 0.6";

/// A small ordinary drive for `insalign check`: a parking lot's aisles (turns both ways, stops,
/// braking), VLP-16 at 1 deg, 60 s, two cars of traffic. The smallest such drive found on which
/// one check decides (bench/results/fleet.md): 40 s, or a city block (left turns only), leave
/// the lever arm and yaw undetermined. A knocked drive's installed-extrinsic.json is still
/// kCheckMount: the car believes its old mount.
inline void simulate_ordinary_drive(const fs::path& dir, int seed, bool knocked) {
  if (fs::exists(dir / "installed-extrinsic.json")) return;
  const fs::path tmp = dir.string() + ".tmp-" + std::to_string(::getpid());
  fs::remove_all(tmp);
  const std::string mount = knocked ? kCheckMountKnocked : kCheckMount;
  const auto [rc, out] = run_command(std::string(INSALIGN_EXE) + " simulate --out " + tmp.string() + " --seed " +
                                     std::to_string(seed) + " --trajectory parking-lot --duration-s 60 --lidar vlp16 "
                                     "--azimuth-step-deg 1 --traffic 2 --extrinsic \"" + mount + "\"" +
                                     (knocked ? std::string(" --knock \"") + kCheckKnock + "\"" : std::string()) + " --quiet");
  if (rc != 0) fs::remove_all(tmp);  // nothing half-made left in the cache
  ASSERT_EQ(rc, 0) << out;
  fs::rename(tmp, dir);
}

/// A copy of a drive whose file `name` is corrupt at line 20.
inline void corrupt_copy(const fs::path& from, const fs::path& to, const std::string& name) {
  if (fs::exists(to / name)) return;
  const fs::path tmp = to.string() + ".tmp";
  fs::remove_all(to);
  fs::remove_all(tmp);
  fs::copy(from, tmp, fs::copy_options::recursive);
  std::ifstream in(from / name);
  std::ofstream out(tmp / name);
  std::string line;
  for (int n = 1; std::getline(in, line); ++n) out << (n == 20 ? std::string("0.1 0.2 not-a-number") : line) << "\n";
  out.close();
  fs::rename(tmp, to);
}

/// The drives every fleet test shares, in one folder. Figure-8s for calibrations: car A's and car
/// B's mounts, car B after a knock (yaw +3 deg, roll +1.5 deg), a copy of A whose pose file is
/// corrupt at line 20. Ordinary drives for checks, all installed as kCheckMount: u1 and u2 unchanged
/// (their checks say ok), u3 unchanged but undecided (inconclusive: yaw and the lever arm), k1 and
/// k2 knocked (recalibrate), u1-corrupt a copy of u1 whose poses_tum.txt is corrupt at line 20.
struct FleetDrives {
  fs::path dir;
};

// Shared by the test processes ctest runs at once: the first one simulates, under a lock.
// Kept after the run on purpose: a cache across test processes and runs, not scratch.
inline const FleetDrives& fleet_drives() {
  static FleetDrives d = [] {
    FleetDrives f{fs::temp_directory_path() / "insalign_fleet_drives_v2"};
    fs::create_directories(f.dir);
    const int lock = ::open((f.dir / ".lock").c_str(), O_RDWR | O_CREAT, 0644);
    ::flock(lock, LOCK_EX);
    simulate_drive(f.dir / "a", 11, "0.5 0.1 1.6 1 2 90");
    simulate_drive(f.dir / "b", 12, "-0.3 0.2 1.8 -1 0.5 180");
    simulate_drive(f.dir / "b-knocked", 13, "-0.3 0.2 1.8 0.5 0.5 183");
    corrupt_copy(f.dir / "a", f.dir / "corrupt", "poses.txt");
    for (int i : {1, 2, 3}) simulate_ordinary_drive(f.dir / ("u" + std::to_string(i)), 20 + i, false);
    for (int i : {1, 2}) simulate_ordinary_drive(f.dir / ("k" + std::to_string(i)), 30 + i, true);
    corrupt_copy(f.dir / "u1", f.dir / "u1-corrupt", "poses_tum.txt");
    ::flock(lock, LOCK_UN);
    ::close(lock);
    return f;
  }();
  return d;
}

/// A manifest row for a check of one of the shared ordinary drives against the car's installed
/// extrinsic (installed/<car>.json, written here: the mount every test car has). tz is left
/// unchecked (no fiducials on a city drive), as a fleet that drives without them would.
inline std::string check_row(const fs::path& drives, const std::string& car, const std::string& date, const std::string& drive) {
  const fs::path installed = drives / "installed" / (car + ".json");
  if (!fs::exists(installed)) {
    fs::create_directories(installed.parent_path());
    fs::copy_file(drives / "u1" / "installed-extrinsic.json", installed, fs::copy_options::overwrite_existing);
  }
  return car + "," + date + ",check,--lidar-dir " + drive + "/lidar --poses " + drive + "/poses_tum.txt,installed/" + car +
         ".json,--set check.unchecked_dofs=tz\n";
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
