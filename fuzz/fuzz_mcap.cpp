// Any input must either open, list and read every message, or throw InputError: no crash, hang,
// unbounded allocation or sanitizer report.
#include <algorithm>
#include <cstdlib>

#include "core/errors.hpp"
#include "fuzz_common.hpp"
#include "recording/mcap.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::filesystem::path path = insalign::fuzz::scratch_file(".mcap", data, size);
  try {
    const auto reader = insalign::io::bag::open_mcap(path);
    (void)reader->describe();
    for (std::uint32_t t = 0; t < reader->topics().size(); ++t) {
      for (const auto& ref : reader->messages(t)) {
        try {
          (void)reader->read_prefix(ref, 64);  // first: partial decompression, not the cache
          const std::vector<std::uint8_t> bytes = reader->read(ref);
          // The view into the cached chunk holds the same bytes as the copy.
          const auto shared = reader->read_shared(ref);
          if (!std::equal(bytes.begin(), bytes.end(), shared.bytes.begin(), shared.bytes.end())) std::abort();
        } catch (const insalign::InputError&) {
          // one bad chunk: the others must still be readable
        }
      }
    }
  } catch (const insalign::InputError&) {
    // expected for malformed input
  }
  return 0;
}
