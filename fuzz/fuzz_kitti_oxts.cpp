// Any input must either parse or throw InputError: no crash, hang or sanitizer report. The input
// is read as an oxts record, as a timestamps line and as a velodyne .bin.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "core/errors.hpp"
#include "inslog/kitti.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  try {
    (void)insalign::io::parse_kitti_oxts_record(text, 1317042145.0, "fuzz.txt", "line 1");
  } catch (const insalign::InputError&) {
    // expected for malformed input
  }
  (void)insalign::io::parse_kitti_time(text);
  try {
    (void)insalign::io::parse_kitti_velodyne(text, "0000000000", "fuzz.bin", 0.0, 0.1);
  } catch (const insalign::InputError&) {
    // expected for malformed input
  }
  return 0;
}
