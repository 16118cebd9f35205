// Any input must either parse or throw InputError: no crash, hang or sanitizer report.
#include "core/errors.hpp"
#include "fuzz_common.hpp"
#include "files/extrinsic_json.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::filesystem::path path = insalign::fuzz::scratch_file(".json", data, size);
  try {
    (void)insalign::io::read_opencalib_extrinsic(path);
  } catch (const insalign::InputError&) {
    // expected for malformed input
  }
  return 0;
}
