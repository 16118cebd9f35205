// Any file given as --poses must either read or throw InputError: format detection (pose files,
// NovAtel ASCII, SBET by content or by name, text exports with and without a mapping) and the
// conversion to the local ENU world, on arbitrary bytes.
#include <cstddef>
#include <cstdint>

#include "core/errors.hpp"
#include "fuzz_common.hpp"
#include "inslog/pose_source.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  // The first byte picks the name (SBETs are also recognised as *.out) and whether a mapping is given.
  const char* extensions[] = {".txt", ".out", ".log", ".csv"};
  const std::filesystem::path path = insalign::fuzz::scratch_file(extensions[data[0] % 4], data + 1, size - 1);
  insalign::io::PoseSourceOptions options;
  options.lidar_time_hint_unix_s = 1700000000.0;
  if (data[0] & 4) {
    options.columns_spec = "time=GPSSeconds:gps-week-seconds,week=GPSWeek,lat=Latitude,lon=Longitude,height=HeightMSL:msl,"
                           "undulation=Undulation,roll=Roll,pitch=Pitch,heading=Heading:cw-from-north,status=Fix:gga";
  }
  try {
    (void)insalign::io::read_pose_source(path, options);
  } catch (const insalign::InputError&) {
    // expected for malformed input
  }
  return 0;
}
