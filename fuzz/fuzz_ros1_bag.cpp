// Any input must either read or throw InputError: no crash, hang or sanitizer report. The input
// is opened as a ROS 1 bag, its topics listed and every message read.
#include <algorithm>
#include <cstdlib>

#include "core/errors.hpp"
#include "fuzz_common.hpp"
#include "recording/ros1_bag.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  namespace bag = insalign::io::bag;
  try {
    const auto reader = bag::open_ros1_bag(insalign::fuzz::scratch_file(".bag", data, size));
    (void)reader->describe();
    for (std::uint32_t t = 0; t < reader->topics().size(); ++t) {
      for (const bag::MessageRef& ref : reader->messages(t)) {
        (void)reader->read_prefix(ref, 64);  // first: a partial (lz4, bz2) decompression
        const std::vector<std::uint8_t> bytes = reader->read(ref);
        // The view into the decompressed chunk holds the same bytes as the copy.
        const auto shared = reader->read_shared(ref);
        if (!std::equal(bytes.begin(), bytes.end(), shared.bytes.begin(), shared.bytes.end())) std::abort();
      }
    }
  } catch (const insalign::InputError&) {
    // expected for malformed input
  }
  return 0;
}
