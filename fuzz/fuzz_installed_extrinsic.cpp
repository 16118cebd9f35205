// Any input must either parse as an installed extrinsic (io/installed_extrinsic.hpp: every format
// `insalign check --extrinsic` takes) or throw InputError: no crash, hang or sanitizer report.
#include <string>

#include "core/errors.hpp"
#include "fuzz_common.hpp"
#include "files/installed_extrinsic.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    (void)insalign::io::parse_installed_extrinsics(text, "fuzz");
  } catch (const insalign::InputError&) {
    // expected for malformed input
  }
  return 0;
}
