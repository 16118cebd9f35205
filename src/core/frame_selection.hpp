// Choosing which frames of a drive a stage uses: groups of consecutive moving frames spread
// evenly over the drive's motion (distance plus turning), so standstill adds nothing.
#pragma once

#include <cstddef>
#include <vector>

#include "core/dataset.hpp"

namespace insalign {

struct FrameSelectionConfig {
  std::size_t groups = 24;             ///< groups spread evenly over the drive's motion measure
  std::size_t frames_per_group = 6;    ///< consecutive moving frames per group
  double min_step_m = 0.1;             ///< a frame joins a group only if it moved this far from the
  double min_step_deg = 1.0;           ///< previous member, or turned this much (standstill skipped)
  double rotation_weight_m_per_rad = 10.0;  ///< motion measure = distance + weight * turned angle
  double time_offset_s = 0.0;          ///< LiDAR to INS clock (frames must be covered by poses)
  double sweep_span_s = 0.1;           ///< poses must cover [t_end - span, t_end] for deskewing
};

struct FrameSelection {
  std::vector<std::vector<std::size_t>> groups;  ///< frame indices, time order within and across groups
  double distance_m = 0.0;             ///< INS path length over the covered frames
  double turned_rad = 0.0;             ///< total INS rotation angle over the covered frames
  std::size_t frames_covered = 0;      ///< frames whose sweep the poses cover
  std::size_t frames_moving = 0;       ///< of those, frames that moved since the previous one

  std::vector<std::size_t> all() const;  ///< every selected frame, time order
};

/// Deterministic; reads only frame times and poses (no sweep is loaded). Groups may be fewer
/// than asked (short or mostly static drives); empty when nothing moves.
FrameSelection select_frames(const Dataset& data, const FrameSelectionConfig& config = {});

}  // namespace insalign
