// T_world_ins from TF: the transforms of /tf (moving) and /tf_static composed along the tree path
// from the world frame to the ins frame, at the stamps of the moving link with the most samples
// (the other moving links interpolated: linear translation, slerp).
//
// Without --ins-frame the ins frame is the end of the moving chain (the only frame that /tf moves
// and that moves nothing itself: base_link in map -> odom -> base_link); static children such as
// sensor mounts are never picked on their own. Without --world-frame the world is the root of the
// ins frame's tree. When the moving transforms end in several frames, the choice is an InputError
// listing the frames and the transforms. Frame names lose a leading '/' (tf1 style).
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "recording/messages.hpp"
#include "inslog/ins_track.hpp"

namespace insalign::io {

struct TfChain {
  std::vector<InsRecord> records;     ///< T_world_ins in time order
  std::string world_frame, ins_frame;
  std::string chain;                  ///< "map -> odom -> base_link (-> gnss static)"
  std::size_t samples_outside = 0;    ///< base stamps where another moving link had no data
  std::vector<std::string> warnings;
};

/// `source` names the bag in errors. world_frame / ins_frame empty: chosen as above.
TfChain tf_chain(const std::vector<bag::TransformStamped>& moving, const std::vector<bag::TransformStamped>& fixed,
                 const std::string& world_frame, const std::string& ins_frame, const std::string& source);

}  // namespace insalign::io
