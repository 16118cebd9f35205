#include "files/config_file.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <fstream>
#include <set>
#include <sstream>

#include "files/read_file.hpp"

namespace insalign::io {
namespace {

std::string line_at(const YAML::Mark& mark) { return "line " + std::to_string(mark.line + 1); }

void flatten(const YAML::Node& node, const std::string& prefix, const std::string& file,
             std::set<std::string>& seen, std::vector<ConfigScalar>& out) {
  for (const auto& kv : node) {
    const YAML::Node& key = kv.first;
    const YAML::Node& value = kv.second;
    if (!key.IsScalar()) throw InputError(file, line_at(key.Mark()), "a key must be a plain name");
    const std::string dotted = prefix.empty() ? key.Scalar() : prefix + "." + key.Scalar();
    if (!seen.insert(dotted).second) throw InputError(file, line_at(key.Mark()), "'" + dotted + "' is given twice");
    if (value.IsMap()) {
      flatten(value, dotted, file, seen, out);
    } else if (value.IsSequence()) {
      // A list of sections: item n's fields become "<key>.n.<field>".
      for (std::size_t n = 0; n < value.size(); ++n) {
        if (!value[n].IsMap()) {
          throw InputError(file, line_at(value[n].Mark()), "'" + dotted + "' takes a list of 'name: value' maps");
        }
        flatten(value[n], dotted + "." + std::to_string(n), file, seen, out);
      }
    } else {
      ConfigScalar s;
      s.key = dotted;
      s.line = key.Mark().line + 1;
      if (value.IsNull()) {
        s.text = "null";
      } else {
        s.text = value.Scalar();
        s.quoted = value.Tag() == "!";  // yaml-cpp tags quoted scalars "!", plain ones "?"
      }
      out.push_back(std::move(s));
    }
  }
}

std::size_t edit_distance(const std::string& a, const std::string& b) {
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diag = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t up = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diag + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diag = up;
    }
  }
  return row[b.size()];
}

std::string last_part(const std::string& key) {
  const auto dot = key.rfind('.');
  return dot == std::string::npos ? key : key.substr(dot + 1);
}

}  // namespace

std::vector<ConfigScalar> parse_config_scalars(std::string_view yaml_text, const std::string& file) {
  YAML::Node root;
  try {
    root = YAML::Load(std::string(yaml_text));
  } catch (const YAML::Exception& e) {
    throw InputError(file, e.mark.is_null() ? "" : line_at(e.mark), e.msg);
  }
  std::vector<ConfigScalar> out;
  if (root.IsNull()) return out;  // an empty file changes nothing
  if (!root.IsMap()) throw InputError(file, line_at(root.Mark()), "expected 'section: {name: value}' maps at the top");
  std::set<std::string> seen;
  flatten(root, "", file, seen, out);
  return out;
}

std::vector<ConfigScalar> read_config_scalars(const std::filesystem::path& path) {
  return parse_config_scalars(read_file(path), path.string());
}

std::optional<bool> config_parse_bool(const std::string& text) {
  std::string t = text;
  std::transform(t.begin(), t.end(), t.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (t == "true" || t == "yes" || t == "on") return true;
  if (t == "false" || t == "no" || t == "off") return false;
  return std::nullopt;
}

std::optional<long long> config_parse_int(const std::string& text) {
  const std::string t = !text.empty() && text[0] == '+' ? text.substr(1) : text;
  long long v = 0;
  const auto [end, ec] = std::from_chars(t.data(), t.data() + t.size(), v);
  if (t.empty() || ec != std::errc() || end != t.data() + t.size()) return std::nullopt;
  return v;
}

std::optional<double> config_parse_double(const std::string& text) {
  const std::string t = !text.empty() && text[0] == '+' ? text.substr(1) : text;
  double v = 0;
  const auto [end, ec] = std::from_chars(t.data(), t.data() + t.size(), v);
  if (t.empty() || ec != std::errc() || end != t.data() + t.size() || !std::isfinite(v)) return std::nullopt;
  return v;
}

std::string config_format_double(double v) {
  char buf[64];
  const auto [end, ec] = std::to_chars(buf, buf + sizeof buf, v);
  std::string s(buf, ec == std::errc() ? end : buf);
  if (s.find_first_of(".eEn") == std::string::npos) s += ".0";  // reads as a number, not an integer
  return s;
}

std::string config_quote(const std::string& s) {
  std::string out = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') out += '\\';
    out += c;
  }
  return out + "\"";
}

std::optional<std::string> config_closest_key(const std::string& key, const std::vector<std::string>& candidates) {
  std::optional<std::string> best;
  std::size_t best_distance = std::max<std::size_t>(2, key.size() / 4) + 1;
  for (const auto& c : candidates) {
    const std::size_t d = edit_distance(key, c);
    if (d < best_distance) {
      best_distance = d;
      best = c;
    }
  }
  if (best) return best;
  // Right name in the wrong section ("min_range_m" at the top instead of under "rough").
  for (const auto& c : candidates)
    if (last_part(c) == last_part(key)) return c;
  return std::nullopt;
}

}  // namespace insalign::io
