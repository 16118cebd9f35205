// Points on things that moved (issue 17): cars, cyclists and people passing through the scene.
// Every stage assumes a static world; a passing car is a surface that is somewhere else in every
// pass, and a car parked over a fiducial for a second lifts the ground there.
//
// Evidence: space seen empty at other times. Each frame of a sample spread over the drive casts
// its rays; a voxel a ray passes through (short of its end) is free in that frame, a voxel a point
// lands in is hit. A static surface is hit whenever it is seen and crossed only by the odd grazing
// ray; a lane or a sidewalk is crossed by most frames that look at it and hit only while something
// is in it. A voxel hit in at most `max_hit_fraction` of the sample frames that observed it (and
// seen free by at least `min_free_frames`) is moving space: any point in it, in any frame, is left
// out. The ground itself is hit and grazed by nearly every frame, so only points more than
// `ground_clearance_m` above the local ground (a low percentile of the heights in a ground cell)
// and below `max_height_m` are judged: what moves on a street stands on it.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

#include "core/frame_store.hpp"
#include "core/frames.hpp"
#include "core/geometry.hpp"
#include "core/voxel_grid.hpp"

namespace insalign {

struct MovingPointsConfig {
  bool enabled = true;             ///< mask points on moving things for every stage
  std::size_t max_frames = 150;    ///< sample frames whose rays give the evidence (spread over the drive)
  /// The sample frames' points (base-thinned copies thinned again); rays end at max_range_m.
  SweepFilter filter{.min_range_m = 0.0, .max_range_m = 40.0, .voxel_m = 0.2, .max_points = 5000};
  double voxel_m = 0.4;            ///< evidence voxels (x, y, height above ground), m
  double ground_cell_m = 1.0;      ///< horizontal cells of the ground height, m
  double ground_percentile = 0.05; ///< the ground height of a cell: this fraction of its points lie below
  double ground_clearance_m = 0.15;  ///< points lower above the ground are ground (never judged), m
  double max_height_m = 3.0;       ///< points higher above the ground are never judged (vans are lower), m
  double end_margin_m = 0.8;       ///< a ray counts as free only up to this short of its point, m
  std::size_t min_free_frames = 3; ///< a voxel seen free by fewer sample frames is not judged
  double max_hit_fraction = 0.2;   ///< hit in at most this fraction of the frames that observed it: moving
  /// A rig: one evidence for every LiDAR, the reference LiDAR's rays (the most stage-1 planes, the
  /// densest view) and every LiDAR's points (find_moving_points over several LiDARs); false: each
  /// LiDAR its own, its rays as expensive as the reference's.
  bool rig_shared = true;
};

template <class V>
void visit_config(V& v, MovingPointsConfig& c) {
  v("enabled", c.enabled, "leave out points on moving things (space seen empty at other times) in every stage");
  v("max_frames", c.max_frames, "sample frames whose rays give the free-space evidence");
  v.section("filter", c.filter);
  v("voxel_m", c.voxel_m, "evidence voxels (x, y, height above ground), m");
  v("ground_cell_m", c.ground_cell_m, "horizontal cells of the local ground height, m");
  v("ground_percentile", c.ground_percentile, "a cell's ground height: this fraction of its points lie below");
  v("ground_clearance_m", c.ground_clearance_m, "points lower above the local ground are ground, never judged, m");
  v("max_height_m", c.max_height_m, "points higher above the local ground are never judged, m");
  v("end_margin_m", c.end_margin_m, "a ray counts as free only up to this short of its point, m");
  v("min_free_frames", c.min_free_frames, "a voxel seen free by fewer sample frames is not judged");
  v("max_hit_fraction", c.max_hit_fraction, "a voxel hit in at most this fraction of the frames observing it is moving space");
  v("rig_shared", c.rig_shared, "rig: one evidence, the reference LiDAR's rays and every LiDAR's points (false: each LiDAR its own)");
}

class MovingPoints;

struct MovingPointsResult {
  bool applied = false;
  std::shared_ptr<const MovingPoints> mask;  ///< what the stages were given (the report colours it)
  std::size_t frames_used = 0;        ///< sample frames
  std::size_t voxels_judged = 0;      ///< voxels above the ground with enough evidence
  std::size_t voxels_moving = 0;      ///< of which hit at least once and found moving
  std::size_t points_checked = 0;     ///< sample-frame points
  std::size_t points_moving = 0;      ///< sample-frame points left out
  double wall_time_s = 0.0;
};

/// The mask: places a frame's points with the poses and extrinsic it was built with and leaves out
/// those in moving space.
class MovingPoints : public PointMask {
 public:
  MovingPoints(PoseStream poses, const Iso3& T_ins_lidar, double time_offset_s, const MovingPointsConfig& config,
               VoxelKeyMap<float> ground_z_m, const std::vector<std::uint64_t>& moving_voxels);
  std::vector<char> keep(std::size_t index, const Sweep& sweep) const override;
  std::vector<char> keep_world(std::size_t index, const std::vector<Vec3f>& p_world) const override;
  /// Whether a world point lies in moving space.
  bool moving(const Vec3f& p_world) const;

 private:
  PoseStream poses_;
  Iso3 T_ins_lidar_;
  double time_offset_s_;
  MovingPointsConfig config_;
  VoxelKeyMap<float> ground_z_m_;  ///< per ground cell
  VoxelKeySet moving_voxels_;       ///< the evidence voxels found moving
  /// The moving voxels as bits over their box, and the ground heights over it: the maps' answers
  /// without their cache misses (every point of every stage and of the report is asked; a
  /// drive's box is tens of kilobytes). Empty when it would be too large: the maps answer.
  struct Box {
    VoxelCell lo;                      ///< the evidence voxel at the box's corner
    std::int64_t w = 0, d = 0, h = 0;  ///< voxels along x, y, height
    std::vector<std::uint64_t> bits;
    std::int64_t gx0 = 0, gy0 = 0, gw = 0, gd = 0;  ///< the ground cells under it
    std::vector<float> ground_z_m;                  ///< NaN: no ground
  };
  Box box_;
  void build_box(const std::vector<std::uint64_t>& moving_voxels);
  bool moving_in_maps(const Vec3f& p_world) const;
};

/// Builds the mask from a sample of the store's frames placed with an extrinsic near the truth
/// (stage 1's: a rotation error moves far points by decimetres, so the evidence needs it).
/// Returns nullptr (and result.applied = false) when disabled or the store has too few frames.
std::shared_ptr<const MovingPoints> find_moving_points(const FrameStore& store, const Iso3& T_ins_lidar,
                                                       double time_offset_s, const MovingPointsConfig& config,
                                                       MovingPointsResult& result);

/// A LiDAR placed for find_moving_points: its store, extrinsic and time offset (stage 1's).
struct MaskedLidar {
  const FrameStore* store = nullptr;
  Iso3 T_ins_lidar = Iso3::Identity();
  double time_offset_s = 0.0;
};

/// A rig: one evidence for every LiDAR. The rays of LiDAR `rays_from` (the densest view) say
/// which space is seen empty, the points of every LiDAR which is hit: a static surface one LiDAR
/// sees and the other's rays cross is hit, not moving; a car that passed is hit in few frames of
/// any. Rays cost most of the evidence; points cost little. Each LiDAR's mask judges its points
/// over its own ground heights (results[l]; voxel counts shared).
void find_moving_points(const std::vector<MaskedLidar>& lidars, std::size_t rays_from, const MovingPointsConfig& config,
                        std::vector<MovingPointsResult>& results);

}  // namespace insalign
