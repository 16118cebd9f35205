// Any recording must either load as Datasets (frames loadable, reports printable) or throw
// InputError: no crash, hang or sanitizer report in topic choice, INS decoding, TF chains, clock
// checks or the sampled clouds. The same bytes also go through the geodetic fiducial reader.
#include "core/errors.hpp"
#include "fuzz_common.hpp"
#include "recording/bag_reader.hpp"
#include "input/bag_dataset.hpp"

namespace {

void load_everything(const std::filesystem::path& path) {
  insalign::io::BagOptions options;
  options.path = path;
  try {
    const insalign::io::BagDatasets d = insalign::io::load_bag(options);
    (void)insalign::io::describe_bag(d.report);
    (void)insalign::io::to_load_report(d.report);
    for (const insalign::Dataset& lidar : d.lidars) {
      for (std::size_t i = 0; i < lidar.frames.frames.size() && i < 3; ++i) {
        try {
          (void)lidar.frames.load(i);
        } catch (const insalign::InputError&) {
          // one bad cloud: the others must still load
        }
      }
    }
  } catch (const insalign::InputError&) {
  }
  try {
    (void)insalign::io::describe_trajectory(insalign::io::load_bag_trajectory(options));
  } catch (const insalign::InputError&) {
  }
  try {
    (void)insalign::io::describe_recording(*insalign::io::bag::open_bag(path));
  } catch (const insalign::InputError&) {
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::filesystem::path path = insalign::fuzz::scratch_file(".bag", data, size);
  load_everything(path);
  try {
    const insalign::LocalEnu enu({48.1, 11.5, 500.0});
    (void)insalign::io::read_bag_fiducials(path, enu, insalign::Vec3::Zero());
  } catch (const insalign::InputError&) {
  }
  return 0;
}
