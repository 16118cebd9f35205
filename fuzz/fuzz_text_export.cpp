// Any input must either parse or throw InputError: no crash, hang or sanitizer report. The first
// line of the input is the column spec, the rest the export (so both parsers are fuzzed).
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

#include "core/errors.hpp"
#include "inslog/text_export.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view input(reinterpret_cast<const char*>(data), size);
  const std::size_t nl = input.find('\n');
  const std::string spec(input.substr(0, nl == std::string_view::npos ? input.size() : nl));
  const std::string_view text = nl == std::string_view::npos ? std::string_view() : input.substr(nl + 1);
  insalign::io::TextExportColumns columns;
  try {
    columns = insalign::io::parse_text_export_columns(spec);
  } catch (const insalign::InputError&) {
    // a bad spec: read without a mapping (the error listing the columns)
  }
  (void)insalign::io::text_export_header(text);
  try {
    (void)insalign::io::parse_text_export(text, "fuzz.csv", columns, 1700000000.0);
  } catch (const insalign::InputError&) {
    // expected for malformed input
  }
  return 0;
}
