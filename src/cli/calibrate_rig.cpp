// Placeholder until the rig pipeline lands (issue 20): a clear usage error, never a wrong result.
#include "cli/calibrate_rig.hpp"

#include "core/errors.hpp"

namespace insalign::cli {

int calibrate_rig(const io::LoadedInput& input, const PipelineConfig&, const RigRunOptions&) {
  throw InputError("--lidar-dir", "", std::to_string(input.lidars.size()) +
                   " LiDARs given: rig calibration is not available in this build yet; calibrate one at a time");
}

}  // namespace insalign::cli
