// Parameters from YAML, declared once beside each struct: every Config struct has a
// `visit_config(V& v, Config& c)` listing its fields (name, field, meaning) and its sections.
// The loader, `insalign config --dump`, the `--set key=value` assignments and the "did you mean"
// suggestions all walk that one declaration, so a key is always the struct path:
//   rough:
//     filter:
//       voxel_m: 0.4
// Enums are spelled by their name tables (core/enum_names.hpp), as on the command line and in
// JSON. Lists of structs (rough.rounds) are YAML sequences of maps and replace the whole list.
// Unknown keys and values of the wrong type are InputErrors naming the file and line.
#pragma once

#include <filesystem>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

#include "core/enum_names.hpp"
#include "core/errors.hpp"

namespace insalign::io {

/// One leaf of a YAML config, flattened to its dotted key (list items by index: "rough.rounds.0.iterations").
struct ConfigScalar {
  std::string key;
  std::string text;     ///< the scalar as written
  bool quoted = false;  ///< written in quotes: a string, never a number
  int line = 0;         ///< 1-based; 0 when not from a file
};

/// Flattens nested maps (and sequences of maps) into dotted keys. Throws InputError(file,
/// "line N", ...) for YAML syntax errors, duplicate keys and empty values.
std::vector<ConfigScalar> parse_config_scalars(std::string_view yaml_text, const std::string& file_for_errors);
std::vector<ConfigScalar> read_config_scalars(const std::filesystem::path& path);

std::optional<bool> config_parse_bool(const std::string& text);      ///< true/false/yes/no/on/off
std::optional<long long> config_parse_int(const std::string& text);
std::optional<double> config_parse_double(const std::string& text);  ///< finite only
std::string config_format_double(double v);  ///< shortest text that reads back exactly, always with '.' or 'e'
std::string config_quote(const std::string& s);  ///< a YAML double-quoted string
/// The closest of `candidates` to `key` by edit distance, if it is close enough to be a typo.
std::optional<std::string> config_closest_key(const std::string& key, const std::vector<std::string>& candidates);

namespace config_detail {

template <class T>
concept Enum = std::is_enum_v<T> && requires { enum_names(T{}); };

/// Text and parsing of one field type.
template <class T>
struct Codec {
  static std::string type_name() {
    if constexpr (std::is_same_v<T, bool>) return "true or false";
    else if constexpr (std::is_integral_v<T>) return std::is_unsigned_v<T> ? "a whole number >= 0" : "a whole number";
    else if constexpr (std::is_floating_point_v<T>) return "a number";
    else if constexpr (std::is_same_v<T, std::optional<double>>) return "a number or null";
    else if constexpr (std::is_same_v<T, std::string>) return "text";
    else return "one of: " + enum_choices<T>();
  }
  static std::string to_yaml(const T& v) {
    if constexpr (std::is_same_v<T, bool>) return v ? "true" : "false";
    else if constexpr (std::is_integral_v<T>) return std::to_string(v);
    else if constexpr (std::is_floating_point_v<T>) return config_format_double(static_cast<double>(v));
    else if constexpr (std::is_same_v<T, std::optional<double>>) return v ? config_format_double(*v) : "null";
    else if constexpr (std::is_same_v<T, std::string>) return config_quote(v);
    else return std::string(enum_name(v));
  }
  static bool from_yaml(const ConfigScalar& s, T& out) {
    if constexpr (std::is_same_v<T, std::string>) {
      out = s.text;
      return true;
    } else {
      if (s.quoted) return false;
      if constexpr (std::is_same_v<T, bool>) {
        const auto v = config_parse_bool(s.text);
        if (v) out = *v;
        return v.has_value();
      } else if constexpr (std::is_integral_v<T>) {
        const auto v = config_parse_int(s.text);
        if (!v || (std::is_unsigned_v<T> && *v < 0)) return false;
        out = static_cast<T>(*v);
        return true;
      } else if constexpr (std::is_floating_point_v<T>) {
        const auto v = config_parse_double(s.text);
        if (v) out = static_cast<T>(*v);
        return v.has_value();
      } else if constexpr (std::is_same_v<T, std::optional<double>>) {
        if (s.text == "null" || s.text == "~") {
          out.reset();
          return true;
        }
        const auto v = config_parse_double(s.text);
        if (v) out = *v;
        return v.has_value();
      } else {
        const auto v = enum_from_name<T>(s.text);
        if (v) out = *v;
        return v.has_value();
      }
    }
  }
};

inline std::string join(const std::string& prefix, std::string_view key) {
  return prefix.empty() ? std::string(key) : prefix + "." + std::string(key);
}

/// Collects every key (lists as "<key>.N.<field>" patterns are matched by prefix).
struct KeysVisitor {
  std::string prefix;
  std::vector<std::string>* keys;
  template <class T>
  void operator()(std::string_view key, T&, std::string_view) { keys->push_back(join(prefix, key)); }
  template <class S>
  void section(std::string_view key, S& sub) {
    KeysVisitor inner{join(prefix, key), keys};
    visit_config(inner, sub);
  }
  template <class S>
  void list(std::string_view key, std::vector<S>&, std::string_view) {
    S item{};
    KeysVisitor inner{join(prefix, key) + ".N", keys};
    visit_config(inner, item);
  }
};

/// Applies the scalars whose keys it meets; marks them used.
struct LoadVisitor {
  std::string prefix;
  const std::vector<ConfigScalar>* scalars;
  std::vector<char>* used;
  const std::string* file;

  void fail(const ConfigScalar& s, const std::string& type_name) const {
    throw InputError(*file, s.line > 0 ? "line " + std::to_string(s.line) : "",
                     "'" + s.key + "' must be " + type_name + ", not " + (s.quoted ? config_quote(s.text) : s.text));
  }
  template <class T>
  void operator()(std::string_view key, T& field, std::string_view) {
    const std::string full = join(prefix, key);
    for (std::size_t i = 0; i < scalars->size(); ++i) {
      const ConfigScalar& s = (*scalars)[i];
      if (s.key != full) continue;
      if (!Codec<T>::from_yaml(s, field)) fail(s, Codec<T>::type_name());
      (*used)[i] = 1;
    }
  }
  template <class S>
  void section(std::string_view key, S& sub) {
    LoadVisitor inner{join(prefix, key), scalars, used, file};
    visit_config(inner, sub);
  }
  template <class S>
  void list(std::string_view key, std::vector<S>& items, std::string_view) {
    const std::string base = join(prefix, key) + ".";
    std::set<std::size_t> indices;
    for (const ConfigScalar& s : *scalars) {
      if (s.key.rfind(base, 0) != 0) continue;
      const std::string rest = s.key.substr(base.size());
      const auto index = config_parse_int(rest.substr(0, rest.find('.')));
      if (index && *index >= 0 && *index < 1000) indices.insert(static_cast<std::size_t>(*index));
    }
    if (indices.empty()) return;
    items.assign(*indices.rbegin() + 1, S{});
    for (std::size_t n = 0; n < items.size(); ++n) {
      LoadVisitor inner{base + std::to_string(n), scalars, used, file};
      visit_config(inner, items[n]);
    }
  }
};

/// Commented YAML of every field, values from the visited struct.
struct DumpVisitor {
  std::string* out;
  int depth = 0;
  bool list_item_start = false;  ///< the next field opens a "- " list item

  std::string indent() const { return std::string(2 * static_cast<std::size_t>(depth), ' '); }
  template <class T>
  void operator()(std::string_view key, T& field, std::string_view meaning) {
    if (list_item_start) {
      *out += std::string(2 * static_cast<std::size_t>(depth - 1), ' ') + "- " + std::string(key) + ": " +
              Codec<T>::to_yaml(field) + "\n";
      list_item_start = false;
      return;
    }
    *out += indent() + "# " + std::string(meaning) + "\n";
    *out += indent() + std::string(key) + ": " + Codec<T>::to_yaml(field) + "\n";
  }
  template <class S>
  void section(std::string_view key, S& sub) {
    if (depth == 0) *out += "\n";
    *out += indent() + std::string(key) + ":\n";
    DumpVisitor inner{out, depth + 1};
    visit_config(inner, sub);
  }
  template <class S>
  void list(std::string_view key, std::vector<S>& items, std::string_view meaning) {
    *out += indent() + "# " + std::string(meaning) + "\n" + indent() + std::string(key) + ":\n";
    for (S& item : items) {
      DumpVisitor inner{out, depth + 2, true};
      visit_config(inner, item);
    }
  }
};

}  // namespace config_detail

/// Every key of Root, in declaration order.
template <class Root>
std::vector<std::string> config_keys() {
  std::vector<std::string> keys;
  Root root{};
  config_detail::KeysVisitor v{"", &keys};
  visit_config(v, root);
  return keys;
}

/// Applies scalars over `root`. Every key must be declared and every value of its type.
template <class Root>
void apply_config(const std::vector<ConfigScalar>& scalars, const std::string& file_for_errors, Root& root) {
  std::vector<char> used(scalars.size(), 0);
  config_detail::LoadVisitor v{"", &scalars, &used, &file_for_errors};
  visit_config(v, root);
  for (std::size_t i = 0; i < scalars.size(); ++i) {
    if (used[i]) continue;
    const ConfigScalar& s = scalars[i];
    const auto close = config_closest_key(s.key, config_keys<Root>());
    throw InputError(file_for_errors, s.line > 0 ? "line " + std::to_string(s.line) : "",
                     "unknown parameter '" + s.key + "'" + (close ? " (did you mean '" + *close + "'?)" : "") +
                         "; `insalign config --dump` lists them all");
  }
}

/// Loads a YAML file over `root` (which holds the defaults).
template <class Root>
void load_config_file(const std::filesystem::path& path, Root& root) {
  apply_config(read_config_scalars(path), path.string(), root);
}

/// Applies `key=value` assignments (the benchmarks' and the CLI's --set); `source` names them in errors.
template <class Root>
void apply_config_assignments(const std::vector<std::string>& assignments, const std::string& source, Root& root) {
  std::vector<ConfigScalar> scalars;
  for (const std::string& a : assignments) {
    const auto eq = a.find('=');
    if (eq == std::string::npos || eq == 0) throw InputError(source, "", "expected key=value, got '" + a + "'");
    scalars.push_back({a.substr(0, eq), a.substr(eq + 1), false, 0});
  }
  apply_config(scalars, source, root);
}

/// Every parameter as commented YAML with its value in `root`, after a commented header.
/// Loading the output back gives `root` again.
template <class Root>
std::string dump_config(Root root, const std::string& header) {
  std::string out;
  std::string line;
  for (char c : header.empty() ? std::string() : header + "\n") {
    if (c != '\n') {
      line += c;
      continue;
    }
    out += "# " + line + "\n";
    line.clear();
  }
  config_detail::DumpVisitor v{&out};
  visit_config(v, root);
  return out;
}

}  // namespace insalign::io
