// The fleet's parsers on any input: the manifest (CSV) and the task status record (JSON) must
// either parse or throw InputError: no crash, hang or sanitizer report.
#include <string_view>

#include "core/errors.hpp"
#include "fleet/manifest.hpp"
#include "fleet/status.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  try {
    const insalign::fleet::Manifest m = insalign::fleet::parse_manifest(text, "fuzz.csv");
    for (const auto& row : m.rows) {
      (void)insalign::fleet::split_words(row.input, "fuzz.csv", "");
      (void)row.id();
    }
  } catch (const insalign::InputError&) {
    // expected for malformed input
  }
  try {
    (void)insalign::fleet::status_from_json(std::string(text), "fuzz.status.json");
  } catch (const insalign::InputError&) {
    // expected for malformed input
  }
  return 0;
}
