// Parameters from a YAML file, without reflection: a table of entries {dotted key, accessor,
// one-line meaning} declares each parameter once, and both the loader and `insalign config --dump`
// read the same table. The YAML maps nest by the dots of the keys:
//   rough:
//     root_voxel_m: 2.0
// Unknown keys and values of the wrong type are InputErrors naming the file and line.
#pragma once

#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>
#include <vector>

#include "core/errors.hpp"
#include "core/pipeline.hpp"
#include "sim/simulate.hpp"

namespace insalign::io {

/// One leaf of a YAML config, flattened to its dotted key.
struct ConfigScalar {
  std::string key;     ///< "rough.root_voxel_m"
  std::string text;    ///< the scalar as written
  bool quoted = false; ///< written in quotes: a string, never a number
  int line = 0;        ///< 1-based
};

/// Flattens nested maps into dotted keys. Throws InputError(file, "line N", ...) for YAML syntax
/// errors, duplicate keys, sequences and empty values.
std::vector<ConfigScalar> parse_config_scalars(std::string_view yaml_text, const std::string& file_for_errors);
std::vector<ConfigScalar> read_config_scalars(const std::filesystem::path& path);

// Scalar conversions shared by every entry; nullopt when the text is not of the type.
std::optional<bool> config_parse_bool(const std::string& text);            ///< true/false/yes/no/on/off
std::optional<long long> config_parse_int(const std::string& text);
std::optional<double> config_parse_double(const std::string& text);        ///< finite only
std::string config_format_double(double v);  ///< shortest text that reads back exactly, always with '.' or 'e'
std::string config_quote(const std::string& s);  ///< a YAML double-quoted string
/// The closest of `candidates` to `key` by edit distance, if it is close enough to be a typo.
std::optional<std::string> config_closest_key(const std::string& key, const std::vector<std::string>& candidates);

/// One parameter of the configuration root `Root`.
template <class Root>
struct ConfigParam {
  std::string key;        ///< dotted path, e.g. "rough.root_voxel_m"
  std::string meaning;    ///< one line, with the unit
  std::string type_name;  ///< what a value must look like, for error messages ("a number", "one of: a, b")
  std::function<std::string(const Root&)> to_yaml;                   ///< current value as YAML text
  std::function<bool(Root&, const ConfigScalar&)> from_yaml;         ///< false: wrong type
};

/// Declares a plain field (bool, integer, floating point or std::string) through an accessor
/// usable on both const and non-const roots: `[](auto& c) -> auto& { return c.rough.voxel_m; }`.
template <class Root, class Access>
ConfigParam<Root> config_field(std::string key, std::string meaning, Access access) {
  using T = std::remove_cvref_t<decltype(access(std::declval<Root&>()))>;
  ConfigParam<Root> p;
  p.key = std::move(key);
  p.meaning = std::move(meaning);
  if constexpr (std::is_same_v<T, bool>) {
    p.type_name = "true or false";
    p.to_yaml = [access](const Root& r) { return std::string(access(r) ? "true" : "false"); };
    p.from_yaml = [access](Root& r, const ConfigScalar& s) {
      const auto v = s.quoted ? std::nullopt : config_parse_bool(s.text);
      if (v) access(r) = *v;
      return v.has_value();
    };
  } else if constexpr (std::is_integral_v<T>) {
    p.type_name = std::is_unsigned_v<T> ? "a whole number >= 0" : "a whole number";
    p.to_yaml = [access](const Root& r) { return std::to_string(access(r)); };
    p.from_yaml = [access](Root& r, const ConfigScalar& s) {
      const auto v = s.quoted ? std::nullopt : config_parse_int(s.text);
      if (!v || (std::is_unsigned_v<T> && *v < 0)) return false;
      access(r) = static_cast<T>(*v);
      return true;
    };
  } else if constexpr (std::is_floating_point_v<T>) {
    p.type_name = "a number";
    p.to_yaml = [access](const Root& r) { return config_format_double(static_cast<double>(access(r))); };
    p.from_yaml = [access](Root& r, const ConfigScalar& s) {
      const auto v = s.quoted ? std::nullopt : config_parse_double(s.text);
      if (v) access(r) = static_cast<T>(*v);
      return v.has_value();
    };
  } else if constexpr (std::is_same_v<T, std::optional<double>>) {
    p.type_name = "a number or null";
    p.to_yaml = [access](const Root& r) {
      const auto& v = access(r);
      return v ? config_format_double(*v) : std::string("null");
    };
    p.from_yaml = [access](Root& r, const ConfigScalar& s) {
      if (!s.quoted && (s.text == "null" || s.text == "~")) {
        access(r).reset();
        return true;
      }
      const auto v = s.quoted ? std::nullopt : config_parse_double(s.text);
      if (v) access(r) = *v;
      return v.has_value();
    };
  } else {
    static_assert(std::is_same_v<T, std::string>, "config_field: use config_enum for enums");
    p.type_name = "text";
    p.to_yaml = [access](const Root& r) { return config_quote(access(r)); };
    p.from_yaml = [access](Root& r, const ConfigScalar& s) {
      access(r) = s.text;
      return true;
    };
  }
  return p;
}

/// Declares an enum field by its names: config_enum<Root>("sim.scene", "...", access, {{"city", Kind::kCity}}).
template <class Root, class Access, class E>
ConfigParam<Root> config_enum(std::string key, std::string meaning, Access access,
                              std::vector<std::pair<std::string, E>> names) {
  ConfigParam<Root> p;
  p.key = std::move(key);
  p.meaning = std::move(meaning);
  p.type_name = "one of:";
  for (std::size_t i = 0; i < names.size(); ++i) p.type_name += (i ? ", " : " ") + names[i].first;
  p.to_yaml = [access, names](const Root& r) {
    for (const auto& [name, value] : names)
      if (access(r) == value) return name;
    return std::string("?");
  };
  p.from_yaml = [access, names](Root& r, const ConfigScalar& s) {
    for (const auto& [name, value] : names) {
      if (s.text == name) {
        access(r) = value;
        return true;
      }
    }
    return false;
  };
  return p;
}

/// Applies parsed scalars to `root`. Every key must be in `params` and every value of its type.
template <class Root>
void apply_config(const std::vector<ConfigParam<Root>>& params, const std::vector<ConfigScalar>& scalars,
                  const std::string& file_for_errors, Root& root) {
  for (const ConfigScalar& s : scalars) {
    const ConfigParam<Root>* param = nullptr;
    for (const auto& p : params)
      if (p.key == s.key) param = &p;
    const std::string where = s.line > 0 ? "line " + std::to_string(s.line) : "";
    if (param == nullptr) {
      std::vector<std::string> keys;
      for (const auto& p : params) keys.push_back(p.key);
      const auto close = config_closest_key(s.key, keys);
      throw InputError(file_for_errors, where,
                       "unknown parameter '" + s.key + "'" + (close ? " (did you mean '" + *close + "'?)" : "") +
                           "; `insalign config --dump` lists them all");
    }
    if (!param->from_yaml(root, s)) {
      throw InputError(file_for_errors, where,
                       "'" + s.key + "' must be " + param->type_name + ", not " + (s.quoted ? config_quote(s.text) : s.text));
    }
  }
}

/// Loads a YAML config file over `root` (which holds the defaults).
template <class Root>
void load_config_file(const std::vector<ConfigParam<Root>>& params, const std::filesystem::path& path, Root& root) {
  apply_config(params, read_config_scalars(path), path.string(), root);
}

/// Applies one `key=value` assignment (e.g. from the command line); source names it in errors.
template <class Root>
void apply_config_assignment(const std::vector<ConfigParam<Root>>& params, const std::string& assignment,
                             const std::string& source, Root& root) {
  const auto eq = assignment.find('=');
  if (eq == std::string::npos || eq == 0) throw InputError(source, "", "expected key=value, got '" + assignment + "'");
  ConfigScalar s;
  s.key = assignment.substr(0, eq);
  s.text = assignment.substr(eq + 1);
  apply_config(params, {s}, source, root);
}

/// Every parameter as commented YAML (its meaning above it, values from `root`), grouped by the
/// dotted prefixes in table order. Loading the output back gives `root` again.
template <class Root>
std::string dump_config(const std::vector<ConfigParam<Root>>& params, const Root& root, const std::string& header) {
  std::string out;
  if (!header.empty()) {
    std::string line;
    for (char c : header + "\n") {
      if (c == '\n') {
        out += "# " + line + "\n";
        line.clear();
      } else {
        line += c;
      }
    }
  }
  std::vector<std::string> open;  // the section path currently open
  for (const auto& p : params) {
    std::vector<std::string> parts;
    for (std::size_t start = 0;;) {
      const auto dot = p.key.find('.', start);
      parts.push_back(p.key.substr(start, dot - start));
      if (dot == std::string::npos) break;
      start = dot + 1;
    }
    std::size_t common = 0;
    while (common < open.size() && common + 1 < parts.size() && open[common] == parts[common]) ++common;
    open.resize(common);
    for (std::size_t i = common; i + 1 < parts.size(); ++i) {
      if (i == 0) out += "\n";
      out += std::string(2 * i, ' ') + parts[i] + ":\n";
      open.push_back(parts[i]);
    }
    const std::string indent(2 * open.size(), ' ');
    out += indent + "# " + p.meaning + "\n";
    out += indent + parts.back() + ": " + p.to_yaml(root) + "\n";
  }
  return out;
}

}  // namespace insalign::io

// ---- The tool's own parameters ------------------------------------------------------------
namespace insalign::io {

/// Everything `--config` can set: the calibration pipeline and the simulator.
struct ToolConfig {
  PipelineConfig calibrate;
  sim::SimConfig sim;
};

/// The table: every parameter once, with its meaning (src/io/config_file.cpp).
const std::vector<ConfigParam<ToolConfig>>& tool_config_params();

/// Defaults overridden by the YAML file. Throws InputError(path, "line N", ...).
ToolConfig load_tool_config(const std::filesystem::path& path, ToolConfig defaults = {});

/// Defaults overridden by `key=value` assignments (the benchmarks' --set). Throws InputError
/// naming `source` and the key.
ToolConfig tool_config_with(const std::vector<std::string>& assignments, const std::string& source = "--set",
                            ToolConfig defaults = {});

/// `insalign config --dump`: commented YAML of every parameter with its value in `config`.
std::string dump_tool_config(const ToolConfig& config = {});

}  // namespace insalign::io
