// Writers for the INS log formats the readers read (the simulator's --poses-format, and tests):
// NovAtel ASCII (#INSPVAXA, #INSPVAA or %INSPVASA with their CRC), POSPac SBET, a CSV export, a
// KITTI oxts/ folder and a whole KITTI raw drive. Input: the INS poses T_world_ins in a local ENU
// world tangent at `origin` (what to_world() gives back), UNIX times, and optionally the INS
// quality per pose. Each writer's output reads back through read_ins_log to the same poses (to
// 0.1 mm and 1e-6 deg or better: the printed precision; SBET is exact).
#pragma once

#include <cstddef>
#include <filesystem>
#include <functional>
#include <vector>

#include "core/dataset.hpp"
#include "core/pose_stream.hpp"
#include "core/sweep.hpp"
#include "core/geodesy.hpp"
#include "inslog/ins_log.hpp"

namespace insalign::io {

enum class NovatelRecord { kInspvaxa, kInspvaa, kInspvasa };

struct InsLogWriteOptions {
  GeodeticPoint origin;                                ///< the world (local ENU) frame's origin
  NovatelRecord novatel_record = NovatelRecord::kInspvaxa;
  /// Geoid undulation written to INSPVAX and the CSV (their heights are above mean sea level =
  /// ellipsoidal - undulation). A constant: the simulator has no geoid. Nonzero, so that a reader
  /// that ignores it is caught; -17 m as in NovAtel's example logs.
  double undulation_m = -17.0;
  /// SBET wander angle (deg, constant): platform heading = true heading + wander. Nonzero for the
  /// same reason (POSPac's wander-azimuth frame is rarely north-aligned).
  double sbet_wander_deg = 5.0;
};

/// `quality` is empty or has one entry per pose. GnssSolution::kUnknown has no code in INSPVAX and
/// is written as INS_RTKFIXED there; a NaN standard deviation is written as 0.02 m.
void write_novatel_ascii(const std::filesystem::path& path, const std::vector<StampedPose>& poses,
                         const std::vector<InsQuality>& quality, const InsLogWriteOptions& options);
void write_sbet(const std::filesystem::path& path, const std::vector<StampedPose>& poses,
                const InsLogWriteOptions& options);
/// Columns as text_export_writer_columns() maps them.
void write_text_export(const std::filesystem::path& path, const std::vector<StampedPose>& poses,
                       const std::vector<InsQuality>& quality, const InsLogWriteOptions& options);
/// oxts/timestamps.txt and oxts/data/NNNNNNNNNN.txt, one record per pose (at the poses' rate, as
/// KITTI's unsynced "extract" drives; the synced ones hold one per sweep).
void write_kitti_oxts(const std::filesystem::path& oxts_dir, const std::vector<StampedPose>& poses,
                      const std::vector<InsQuality>& quality, const InsLogWriteOptions& options);

/// The mapping of the CSV write_text_export writes (GPS week + seconds, height above mean sea level
/// with an undulation column, aerospace angles, standard deviations, a GGA quality column).
inline constexpr const char* kTextExportWriterSpec =
    "time=GPSSeconds:gps-week-seconds,week=GPSWeek,lat=Latitude,lon=Longitude,height=HeightMSL:msl,"
    "undulation=Undulation,roll=Roll,pitch=Pitch,heading=Heading:cw-from-north,units=deg,"
    "frame=x-forward-y-right-z-down,sd-east=SDEast,sd-north=SDNorth,sd-up=SDUp,status=Fix:gga";
TextExportColumns text_export_writer_columns();

/// The format's file (kKittiOxts: the oxts folder) by the writers above.
void write_ins_log(const std::filesystem::path& path, InsLogFormat format, const std::vector<StampedPose>& poses,
                   const std::vector<InsQuality>& quality, const InsLogWriteOptions& options);

/// A KITTI raw drive: drive_dir/oxts (write_kitti_oxts), drive_dir/velodyne_points (one .bin per
/// sweep; timestamps_start/_end fitted to the sweep's point times against their azimuth, so that
/// read_kitti_velodyne gives them back; timestamps.txt their midpoint) and
/// drive_dir/../calib_imu_to_velo.txt holding T_ins_lidar_calib (as T_velo_imu). Sweeps must be
/// clockwise spins starting behind the sensor with per-point times (std::invalid_argument if not).
void write_kitti_drive(const std::filesystem::path& drive_dir, const std::vector<Sweep>& sweeps,
                       const std::vector<StampedPose>& poses, const std::vector<InsQuality>& quality,
                       const Iso3& T_ins_lidar_calib, const InsLogWriteOptions& options);
/// The same with the sweeps made on demand: `sweep_at(i)` is called once per index, from several
/// threads at a time (it must be thread-safe), so that a long drive never sits in memory;
/// `done(n)` (optional) after each sweep written, n so far.
void write_kitti_drive(const std::filesystem::path& drive_dir, std::size_t sweep_count,
                       const std::function<Sweep(std::size_t)>& sweep_at, const std::vector<StampedPose>& poses,
                       const std::vector<InsQuality>& quality, const Iso3& T_ins_lidar_calib,
                       const InsLogWriteOptions& options, const std::function<void(std::size_t)>& done = {});

}  // namespace insalign::io
