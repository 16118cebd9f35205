// Any input must either parse or throw InputError: no crash, hang or sanitizer report.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "core/errors.hpp"
#include "inslog/novatel_ascii.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  try {
    (void)insalign::io::parse_novatel_ascii(text, "fuzz.log");
  } catch (const insalign::InputError&) {
    // expected for malformed input
  }
  (void)insalign::io::looks_like_novatel_ascii(text);
  return 0;
}
