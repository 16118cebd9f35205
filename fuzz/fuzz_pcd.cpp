// Any input must either parse or throw InputError: no crash, hang or sanitizer report.
#include "core/errors.hpp"
#include "fuzz_common.hpp"
#include "pointcloud/pcd.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::filesystem::path path = insalign::fuzz::scratch_file(".pcd", data, size);
  try {
    (void)insalign::io::read_pcd(path);
  } catch (const insalign::InputError&) {
    // expected for malformed input
  }
  return 0;
}
