// The documents name exactly the command line and the configuration the tool has: every option in
// any subcommand's --help and every key of `config --dump` appears in README.md or docs/, and every
// option (`--name`) or key (`section.key`) the documents name exists. The subcommands are read
// from `insalign --help` itself (and nested ones from each --help), so new commands are covered
// without touching this test.
#include <gtest/gtest.h>

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "cli_test_util.hpp"

namespace {

namespace fs = std::filesystem;
using insalign::testing::run_command;

std::vector<std::string> lines_of(const std::string& text) {
  std::vector<std::string> out;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) out.push_back(line);
  return out;
}

std::string trim(const std::string& s) {
  const auto b = s.find_first_not_of(" \t");
  if (b == std::string::npos) return "";
  return s.substr(b, s.find_last_not_of(" \t") - b + 1);
}

bool option_char(char c) { return std::islower(static_cast<unsigned char>(c)) || std::isdigit(static_cast<unsigned char>(c)) || c == '-'; }
bool word_char(char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_'; }

/// Every `--name` in a text, where `--` starts a token (not inside a word or a longer dash run).
std::vector<std::string> options_in(const std::string& text) {
  std::vector<std::string> out;
  for (std::size_t i = text.find("--"); i != std::string::npos; i = text.find("--", i + 2)) {
    if (i > 0 && (word_char(text[i - 1]) || text[i - 1] == '-')) continue;
    if (i + 2 >= text.size() || !std::islower(static_cast<unsigned char>(text[i + 2]))) continue;
    std::size_t e = i + 2;
    while (e < text.size() && option_char(text[e])) ++e;
    while (text[e - 1] == '-') --e;
    out.push_back(text.substr(i, e - i));
  }
  return out;
}

// ---- The tool, as its --help and config --dump describe it --------------------------------------

struct Cli {
  std::map<std::string, std::set<std::string>> options;  ///< "calibrate", "fleet run": its options
  std::set<std::string> all_options;                     ///< every subcommand's, and the global ones
  std::set<std::string> keys;                            ///< config keys, list indices left out
  std::set<std::string> sections;                        ///< their prefixes ("refine", "refine.joint")
};

/// The option and subcommand lines of one --help text.
void parse_help(const std::string& help, std::set<std::string>& options, std::vector<std::string>& subcommands) {
  bool in_subcommands = false;
  for (const std::string& line : lines_of(help)) {
    if (line.starts_with("Subcommands:")) in_subcommands = true;
    else if (!line.empty() && line[0] != ' ') in_subcommands = false;
    const std::string t = trim(line);
    if (in_subcommands && line.starts_with("  ") && !t.empty() && std::islower(static_cast<unsigned char>(t[0])))
      subcommands.push_back(t.substr(0, t.find(' ')));
    if (!in_subcommands && t.starts_with("-")) {
      // "-q,--quiet  ..." or "--lidar-dir TEXT ...": the option names before the description.
      for (const std::string& o : options_in(t.substr(0, t.find("  ")))) options.insert(o);
    }
  }
}

void read_command(const std::string& exe, const std::string& path, Cli& cli) {
  const auto [code, help] = run_command(exe + " " + path + " --help");
  ASSERT_EQ(code, 0) << path << " --help:\n" << help;
  std::set<std::string> options;
  std::vector<std::string> subcommands;
  parse_help(help, options, subcommands);
  cli.options[path] = options;
  cli.all_options.insert(options.begin(), options.end());
  for (const std::string& sub : subcommands) read_command(exe, path.empty() ? sub : path + " " + sub, cli);
}

/// Key paths of the dump: "rough.rounds.frame_stride" for a field of a list item.
void parse_dump(const std::string& dump, Cli& cli) {
  std::vector<std::pair<std::size_t, std::string>> stack;  // (indent, name) of the open sections
  for (const std::string& raw : lines_of(dump)) {
    const std::string t = trim(raw);
    if (t.empty() || t[0] == '#') continue;
    std::size_t indent = raw.find_first_not_of(' ');
    std::string rest = t;
    if (rest.starts_with("- ")) rest = rest.substr(2), indent += 2;
    const auto colon = rest.find(':');
    if (colon == std::string::npos) continue;
    while (!stack.empty() && stack.back().first >= indent) stack.pop_back();
    std::string path;
    for (const auto& [_, name] : stack) path += name + ".";
    path += rest.substr(0, colon);
    if (trim(rest.substr(colon + 1)).empty()) {
      stack.emplace_back(indent, rest.substr(0, colon));
      cli.sections.insert(path);
    } else {
      cli.keys.insert(path);
    }
  }
}

const Cli& cli() {
  static const Cli parsed = [] {
    Cli c;
    read_command(INSALIGN_EXE, "", c);
    c.options.erase("");  // the global options count for every command
    for (auto& [_, options] : c.options) options.insert({"--help", "--version"});
    c.all_options.insert({"--help", "--version"});
    const auto [code, dump] = run_command(std::string(INSALIGN_EXE) + " config --dump");
    EXPECT_EQ(code, 0) << dump;
    parse_dump(dump, c);
    return c;
  }();
  return parsed;
}

// ---- The documents ---------------------------------------------------------------------------

struct Page {
  std::string path;  ///< relative to the source tree
  std::string text;
};

std::vector<Page> pages() {
  const fs::path root = INSALIGN_SOURCE_DIR;
  std::vector<fs::path> files = {root / "README.md"};
  for (const auto& e : fs::directory_iterator(root / "docs"))
    if (e.path().extension() == ".md") files.push_back(e.path());
  std::sort(files.begin(), files.end());
  std::vector<Page> out;
  for (const fs::path& f : files) {
    std::ifstream in(f);
    std::stringstream s;
    s << in.rdbuf();
    out.push_back({fs::relative(f, root).string(), s.str()});
  }
  return out;
}

/// A piece of a page that names options or keys, with what it is about.
struct Mention {
  std::string where;  ///< "docs/rigs.md:12"
  std::string text;
  bool code = false;  ///< in a code span or block (keys are only looked for there)
};

/// Code blocks as logical commands (continuation lines joined), code spans, and prose.
std::vector<Mention> mentions(const Page& page) {
  std::vector<Mention> out;
  bool fenced = false;
  const std::vector<std::string> lines = lines_of(page.text);
  for (std::size_t n = 0; n < lines.size(); ++n) {
    const std::string where = page.path + ":" + std::to_string(n + 1);
    const std::string t = trim(lines[n]);
    if (t.starts_with("```")) {
      fenced = !fenced;
      continue;
    }
    if (fenced) {
      const bool continues = !out.empty() && out.back().code && (t.starts_with("[") || t.starts_with("-")) &&
                             out.back().where.starts_with(page.path);
      const bool after_backslash = !out.empty() && out.back().text.ends_with("\\");
      if ((continues || after_backslash) && n > 0 && !trim(lines[n - 1]).starts_with("```"))
        out.back().text += " " + t;
      else
        out.push_back({where, t, true});
      continue;
    }
    std::string prose;
    for (std::size_t i = 0; i < t.size();) {
      if (t[i] != '`') {
        prose += t[i++];
        continue;
      }
      const std::size_t ticks = std::min(t.find_first_not_of('`', i), t.size()) - i;
      const std::size_t end = t.find(std::string(ticks, '`'), i + ticks);
      if (end == std::string::npos) {
        prose += t.substr(i);
        break;
      }
      out.push_back({where, trim(t.substr(i + ticks, end - i - ticks)), true});
      prose += ' ';
      i = end + ticks;
    }
    out.push_back({where, prose, false});
  }
  return out;
}

/// Which command a piece of code is about: "calibrate", "fleet run"; "*" for any (a bare option
/// or prose); "" for another program (cmake, bench/paper_tables...) or a command this build lacks.
std::string command_of(const Mention& m, const Cli& c) {
  if (!m.code) return "*";
  std::istringstream words(m.text);
  std::string first;
  words >> first;
  if (first.starts_with("$")) words >> first;
  if (first.starts_with("-") || first.starts_with("[-")) return "*";
  std::string program = first.substr(first.find_last_of('/') + 1);
  std::string path;
  if (program != "insalign") {
    if (!c.options.contains(program)) return "";
    path = program;  // "simulate --config FILE" in a sentence
  }
  for (std::string w; words >> w;) {
    const std::string longer = path.empty() ? w : path + " " + w;
    if (!c.options.contains(longer)) break;
    path = longer;
  }
  if (path.empty()) {
    std::istringstream again(m.text);
    std::string prog, next;
    again >> prog >> next;
    return next.empty() || next.starts_with("-") ? "*" : "";  // "insalign --help" or a command not built here
  }
  return path;
}

/// `section.key` tokens whose first part is a configuration section; file names are not keys.
std::vector<std::string> keys_in(const std::string& text, const Cli& c) {
  static const std::set<std::string> kFileExtensions = {"json", "html", "md", "txt", "yaml", "yml", "png", "csv",
                                                        "sh", "xml", "pcd", "ply", "bag", "mcap", "db3", "log",
                                                        "out", "sqlite", "hpp", "cpp", "svg", "urdf", "sbatch"};
  std::vector<std::string> out;
  for (std::size_t i = 0; i < text.size(); ++i) {
    if (!std::islower(static_cast<unsigned char>(text[i]))) continue;
    if (i > 0 && (word_char(text[i - 1]) || std::string("./-").find(text[i - 1]) != std::string::npos)) continue;
    std::size_t e = i;
    while (e < text.size() && (word_char(text[e]) || text[e] == '.' || text[e] == '[' || text[e] == ']' || text[e] == '*'))
      ++e;
    std::string token = text.substr(i, e - i);
    i = e;
    while (token.ends_with(".")) token.pop_back();
    const auto dot = token.find('.');
    if (dot == std::string::npos || !c.sections.contains(token.substr(0, dot))) continue;
    if (kFileExtensions.contains(token.substr(token.find_last_of('.') + 1))) continue;
    std::string plain;  // list indices left out: rough.rounds[0].iterations -> rough.rounds.iterations
    for (std::size_t k = 0; k < token.size(); ++k) {
      if (token[k] == '[') k = token.find(']', k);
      else plain += token[k];
      if (k == std::string::npos) break;
    }
    out.push_back(plain);
  }
  return out;
}

bool key_exists(const std::string& key, const Cli& c) {
  if (c.keys.contains(key) || c.sections.contains(key)) return true;
  if (key.ends_with(".*")) return c.sections.contains(key.substr(0, key.size() - 2));
  return false;
}

std::string all_text() {
  std::string text;
  for (const Page& p : pages()) text += p.text + "\n";
  return text;
}

bool names_option(const std::string& text, const std::string& option) {
  for (const std::string& o : options_in(text))
    if (o == option) return true;
  return false;
}

TEST(Docs, EveryOptionOfEveryCommandIsDocumented) {
  const Cli& c = cli();
  ASSERT_TRUE(c.options.contains("calibrate")) << "insalign --help lists no calibrate: the help format changed?";
  const std::string text = all_text();
  for (const auto& [command, options] : c.options) {
    for (const std::string& option : options) {
      if (option == "--help" || option == "--version") continue;
      EXPECT_TRUE(names_option(text, option))
          << "`insalign " << command << " " << option << "` is in its --help but in no page of README.md or docs/";
    }
  }
}

TEST(Docs, EveryConfigKeyIsDocumented) {
  const Cli& c = cli();
  ASSERT_GT(c.keys.size(), 100u) << "config --dump gave too few keys: its format changed?";
  std::set<std::string> named;
  for (const Page& p : pages())
    for (const Mention& m : mentions(p))
      if (m.code)
        for (const std::string& k : keys_in(m.text, c)) named.insert(k);
  for (const std::string& key : c.keys) {
    if (key.find('.') == std::string::npos) {
      EXPECT_TRUE(all_text().find("`" + key + "`") != std::string::npos) << "top-level key `" << key << "` is in no page";
      continue;
    }
    EXPECT_TRUE(named.contains(key)) << "config key `" << key << "` (config --dump) is in no page of README.md or docs/";
  }
}

TEST(Docs, EveryOptionTheDocsNameExists) {
  const Cli& c = cli();
  std::size_t checked = 0;
  for (const Page& p : pages()) {
    for (const Mention& m : mentions(p)) {
      const std::string command = command_of(m, c);
      if (command.empty()) continue;
      const std::set<std::string>& valid = command == "*" ? c.all_options : c.options.at(command);
      for (const std::string& option : options_in(m.text)) {
        ++checked;
        EXPECT_TRUE(valid.contains(option))
            << m.where << ": `" << option << "` is not an option of "
            << (command == "*" ? std::string("any insalign command") : "`insalign " + command + "`") << " (its --help)";
      }
    }
  }
  EXPECT_GT(checked, 50u) << "the documents name hardly any option: the scan is broken?";
}

TEST(Docs, EveryConfigKeyTheDocsNameExists) {
  const Cli& c = cli();
  std::size_t checked = 0;
  for (const Page& p : pages()) {
    for (const Mention& m : mentions(p)) {
      if (!m.code) continue;
      for (const std::string& key : keys_in(m.text, c)) {
        ++checked;
        EXPECT_TRUE(key_exists(key, c)) << m.where << ": `" << key << "` is not a key of `insalign config --dump`";
      }
    }
  }
  EXPECT_GT(checked, 100u) << "the documents name hardly any config key: the scan is broken?";
}

// The scanners themselves, on texts whose answer is known.
TEST(Docs, ScannersFindWhatTheyShould) {
  EXPECT_EQ(options_in("a `--lidar-dir` and --poses-columns, not x--y nor --- or -- or --Caps"),
            (std::vector<std::string>{"--lidar-dir", "--poses-columns"}));
  Cli c;
  parse_dump("# header\na: 1\nrough:\n  # m\n  voxel_m: 1\n  rounds:\n    - w: 1\n      s: 2\n    - w: 3\n      s: 4\n  after: 5\n",
             c);
  EXPECT_EQ(c.keys, (std::set<std::string>{"a", "rough.voxel_m", "rough.rounds.w", "rough.rounds.s", "rough.after"}));
  EXPECT_EQ(c.sections, (std::set<std::string>{"rough", "rough.rounds"}));
  EXPECT_EQ(keys_in("--set rough.voxel_m=2, rough.rounds[1].s, rough.json, stages.rough.x, rough.*", c),
            (std::vector<std::string>{"rough.voxel_m", "rough.rounds.s", "rough.*"}));
  c.options["calibrate"] = {"--out"};
  c.options["fleet"] = {};
  c.options["fleet run"] = {"--jobs"};
  EXPECT_EQ(command_of({"", "build/src/insalign fleet run m.csv --jobs 2", true}, c), "fleet run");
  EXPECT_EQ(command_of({"", "insalign calibrate --out x", true}, c), "calibrate");
  EXPECT_EQ(command_of({"", "insalign notyet --x", true}, c), "");
  EXPECT_EQ(command_of({"", "cmake --build build", true}, c), "");
  EXPECT_EQ(command_of({"", "--out DIR", true}, c), "*");
  EXPECT_EQ(command_of({"", "prose --out", false}, c), "*");
}

}  // namespace
