// Any input must either parse or throw InputError: no crash, hang or sanitizer report.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "core/errors.hpp"
#include "inslog/sbet.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);
  (void)insalign::io::looks_like_sbet(bytes);
  try {
    (void)insalign::io::parse_sbet(bytes, "fuzz.out", 1700000000.0);
  } catch (const insalign::InputError&) {
    // expected for malformed input
  }
  return 0;
}
