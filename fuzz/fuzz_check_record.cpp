// Any input must either parse as a check.json history record (io/check_outputs.hpp) or throw
// InputError: no crash, hang or sanitizer report.
#include <string>

#include "core/errors.hpp"
#include "fuzz_common.hpp"
#include "report/check_outputs.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    (void)insalign::io::parse_check_record(text, "fuzz");
  } catch (const insalign::InputError&) {
    // expected for malformed input
  }
  return 0;
}
