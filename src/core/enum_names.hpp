// One name table per enum, declared beside the enum and found by argument-dependent lookup
// (`enum_names(E{})`), so that YAML, the command line and JSON spell every value the same way.
#pragma once

#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <utility>

namespace insalign {

template <class E>
std::string_view enum_name(E value) {
  for (const auto& [v, name] : enum_names(E{}))
    if (v == value) return name;
  return "?";
}

template <class E>
std::optional<E> enum_from_name(std::string_view name) {
  for (const auto& [v, n] : enum_names(E{}))
    if (n == name) return v;
  return std::nullopt;
}

/// "a, b or c": the accepted names, for messages and help texts.
template <class E>
std::string enum_choices() {
  std::string out;
  const auto names = enum_names(E{});
  for (std::size_t i = 0; i < names.size(); ++i) {
    if (i > 0) out += i + 1 == names.size() ? " or " : ", ";
    out += names[i].second;
  }
  return out;
}

}  // namespace insalign
