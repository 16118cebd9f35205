// KITTI raw drives (cvlibs.net raw data, "..._sync" or "..._extract" folders):
//   DRIVE/oxts/data/NNNNNNNNNN.txt   one OXTS RT3003 record per file: 30 numbers, lat lon alt roll
//                                    pitch yaw vn ve vf vl vu ax ay az af al au wx wy wz wf wl wu
//                                    pos_accuracy vel_accuracy navstat numsats posmode velmode orimode
//   DRIVE/oxts/timestamps.txt        one "2011-09-26 13:02:25.964389445" per record
//   DRIVE/velodyne_points/data/NNNNNNNNNN.bin   float32 x y z reflectance per point (HDL-64E)
//   DRIVE/velodyne_points/timestamps{,_start,_end}.txt   laser facing forward, sweep start, sweep end
//   DRIVE/../calib_imu_to_velo.txt   R: (9) T: (3), T_velo_imu: IMU coordinates into Velodyne ones
//
// Conventions (KITTI raw devkit readme, dataformat.txt):
// - `ins` = the OXTS IMU frame, x forward, y left, z up; roll (positive: left side up), pitch
//   (positive: front down), yaw (0 = east, counter-clockwise), radians: R_enu_ins_enu.
// - lat/lon in degrees; alt in metres as the OXTS wrote it: its values (about 116 m in Karlsruhe,
//   where the ground lies about 115 m above sea level) are heights above mean sea level, and no
//   undulation is given. They are used as they are: a near-constant offset over a drive, which
//   moves the local ENU origin vertically and leaves T_ins_lidar unchanged.
// - Timestamps are the recording computer's clock written without a time zone; read as UTC. All
//   KITTI streams share that clock (the devkit and paper do not say which zone), so the extrinsic
//   and the LiDAR-INS offset do not depend on it; GPS-time comparisons to other data would.
// - posmode is the OXTS NCOM GPS position mode (the devkit refers to the OXTS driver's
//   gps_mode_to_string): 0 none, 1 search, 2 Doppler, 3 SPS, 4 differential, 5 RTK float,
//   6 RTK integer, 7 WAAS, 8/9 OmniSTAR (HP), 10 no data, 11 blanked, 12-16 the same post-processed,
//   17 OmniSTAR XP, 18 CDGPS, 20-29 gx/ix Doppler, SPS, differential, float, integer, 30/31 PPP.
//   navstat is the NCOM navigation status; 4 (locked, real time) and 22 (triggered, locked) are
//   navigating, anything else marks the record kInvalid. pos_accuracy is taken as the one-sigma
//   error of east and of north (the devkit: "north/east in m").
// - Velodyne: no per-point time in the .bin. The HDL-64E spins clockwise seen from above (the
//   sensor's own azimuth counts clockwise; KITTI's readme says counter-clockwise, but the widely
//   used per-point times for KITTI raw, e.g. KISS-ICP's and CT-ICP's, are clockwise, and deskewing
//   with them works); a sweep starts and ends facing backwards (x = -1), the cameras fire at mid
//   sweep facing forward. A point at azimuth a = atan2(y, x) is taken at fraction
//   (pi - a) / (2 pi) of the sweep between timestamps_start and timestamps_end.
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "core/dataset.hpp"
#include "core/sweep.hpp"
#include "inslog/ins_track.hpp"

namespace insalign::io {

enum class VelodyneSpin { kClockwise, kCounterClockwise };

/// OXTS NCOM GPS position mode -> GnssSolution (table above); kUnknown for values it does not list.
GnssSolution oxts_gps_mode_solution(int posmode);

/// "2011-09-26 13:02:25.964389445" (read as UTC) -> UNIX seconds; nullopt if not that shape.
std::optional<double> parse_kitti_time(std::string_view text);
/// A KITTI timestamps file, one time per line. Throws InputError(file, "line N", what).
std::vector<double> read_kitti_timestamps(const std::filesystem::path& file);

/// One oxts data line (30 numbers) at time t_s. Throws InputError(file, where, what).
InsRecord parse_kitti_oxts_record(std::string_view text, double t_s, const std::string& file, const std::string& where);
/// An oxts/ folder: timestamps.txt and data/NNNNNNNNNN.txt, into a geodetic InsTrack.
InsTrack read_kitti_oxts(const std::filesystem::path& oxts_dir);
/// True if `dir` is an oxts folder (timestamps.txt and data/ with .txt files).
bool is_kitti_oxts_dir(const std::filesystem::path& dir);

/// Fraction [0, 1) of the sweep at which a point at (x, y) was measured (see above).
double kitti_sweep_fraction(double x_m, double y_m, VelodyneSpin spin = VelodyneSpin::kClockwise);
/// A velodyne .bin as a Sweep ending at t_end_s, per-point dt_s from the azimuth between t_start_s
/// and t_end_s; reflectance -> intensity, name = the file's stem; non-finite points dropped.
/// Throws InputError(file, "byte N", ...) for a size that is not a multiple of 16.
Sweep read_kitti_velodyne(const std::filesystem::path& bin, double t_start_s, double t_end_s,
                          VelodyneSpin spin = VelodyneSpin::kClockwise);
Sweep parse_kitti_velodyne(std::string_view bytes, const std::string& name, const std::string& file, double t_start_s,
                           double t_end_s, VelodyneSpin spin = VelodyneSpin::kClockwise);

struct KittiFrame {
  std::string name;              ///< the .bin's stem, "0000000042"
  std::filesystem::path bin;
  double t_start_s = 0.0, t_end_s = 0.0;  ///< sweep start and end (UNIX, KITTI clock)
  double t_forward_s = 0.0;               ///< timestamps.txt: facing forward, cameras triggered
};

struct KittiDrive {
  std::filesystem::path drive_dir;
  std::vector<KittiFrame> frames;        ///< time order, those whose .bin exists
  InsTrack ins;                          ///< from oxts/
  std::optional<Iso3> T_ins_lidar_init;  ///< inverse of calib_imu_to_velo.txt's T_velo_imu, if found
  std::filesystem::path calib_file;      ///< where calib_imu_to_velo.txt was looked for
  VelodyneSpin spin = VelodyneSpin::kClockwise;
  std::vector<std::string> warnings;     ///< frames skipped, calibration missing, ...
};

/// Reads a drive folder (the one holding velodyne_points/ and oxts/). Throws InputError.
KittiDrive read_kitti_drive(const std::filesystem::path& drive_dir, VelodyneSpin spin = VelodyneSpin::kClockwise);
/// Frames (t_end_s = sweep end) with a loader reading each .bin on demand.
FrameSource kitti_frame_source(const KittiDrive& drive);

/// Writers (the simulator's --poses-format kitti; tests): a timestamps file, a velodyne .bin.
void write_kitti_timestamps(const std::filesystem::path& file, const std::vector<double>& t_unix_s);
void write_kitti_velodyne(const std::filesystem::path& bin, const Sweep& sweep);

}  // namespace insalign::io
