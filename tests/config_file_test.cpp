#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

#include "tool/tool_config.hpp"
#include "core/errors.hpp"
#include "files/config_file.hpp"

namespace insalign {
namespace {

enum class Colour { kRed, kGreen };
inline constexpr std::array<std::pair<Colour, std::string_view>, 2> kColourNames{
    {{Colour::kRed, "red"}, {Colour::kGreen, "green"}}};
constexpr auto enum_names(Colour) { return std::span(kColourNames); }

struct Inner {
  double voxel_m = 0.5;
  int iterations = 4;
};
template <class V>
void visit_config(V& v, Inner& c) {
  v("voxel_m", c.voxel_m, "voxel edge, m");
  v("iterations", c.iterations, "iterations");
}

struct Small {
  Inner stage;
  bool deskew = true;
  std::size_t frames = 100;
  std::string name = "a b";
  Colour colour = Colour::kRed;
  std::optional<double> height_m;
  std::vector<Inner> rounds{{0.5, 1}, {0.25, 2}};
};
template <class V>
void visit_config(V& v, Small& c) {
  v.section("stage", c.stage);
  v("deskew", c.deskew, "use point times");
  v("frames", c.frames, "frames used");
  v("name", c.name, "a label");
  v("colour", c.colour, "red or green");
  v("height_m", c.height_m, "height, m");
  v.list("rounds", c.rounds, "the schedule");
}

Small load(const std::string& yaml) {
  Small s;
  io::apply_config(io::parse_config_scalars(yaml, "test.yaml"), "test.yaml", s);
  return s;
}

TEST(ConfigFile, OverridesOnlyWhatIsGiven) {
  const Small s = load("stage:\n  voxel_m: 0.25\ncolour: green\nheight_m: 1.25\n");
  EXPECT_EQ(s.stage.voxel_m, 0.25);
  EXPECT_EQ(s.stage.iterations, 4);  // default kept
  EXPECT_TRUE(s.deskew);
  EXPECT_EQ(s.colour, Colour::kGreen);
  ASSERT_TRUE(s.height_m.has_value());
  EXPECT_EQ(*s.height_m, 1.25);
  EXPECT_EQ(s.rounds.size(), 2u);  // a list not given keeps its default
  const Small t = load("deskew: no\nframes: 7\nname: \"12\"\nstage: {iterations: 9}\n");
  EXPECT_FALSE(t.deskew);
  EXPECT_EQ(t.frames, 7u);
  EXPECT_EQ(t.name, "12");
  EXPECT_EQ(t.stage.iterations, 9);
  EXPECT_EQ(load("").stage.voxel_m, 0.5);  // empty file: defaults
}

TEST(ConfigFile, AListReplacesTheWholeSchedule) {
  const Small s = load("rounds:\n  - {voxel_m: 2.0}\n  - {iterations: 7}\n  - {voxel_m: 0.1, iterations: 3}\n");
  ASSERT_EQ(s.rounds.size(), 3u);
  EXPECT_EQ(s.rounds[0].voxel_m, 2.0);
  EXPECT_EQ(s.rounds[0].iterations, Inner{}.iterations);  // fields not given: the struct's defaults
  EXPECT_EQ(s.rounds[1].iterations, 7);
  EXPECT_EQ(s.rounds[2].voxel_m, 0.1);
}

void expect_error(const std::string& yaml, const std::string& location, const std::string& fragment) {
  try {
    load(yaml);
    FAIL() << "no error for:\n" << yaml;
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), "test.yaml");
    EXPECT_EQ(e.location(), location) << e.what();
    EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
  }
}

TEST(ConfigFile, UnknownKeysAndWrongTypesNameTheLine) {
  expect_error("stage:\n  voxel_m: 0.3\n  voxel: 0.2\n", "line 3", "did you mean 'stage.voxel_m'");
  expect_error("voxel_m: 0.2\n", "line 1", "did you mean 'stage.voxel_m'");  // right name, wrong section
  expect_error("\n\nstage:\n  iterations: 2.5\n", "line 4", "must be a whole number");
  expect_error("stage:\n  voxel_m: fast\n", "line 2", "must be a number");
  expect_error("stage:\n  voxel_m: \"0.3\"\n", "line 2", "must be a number");  // quoted: a string
  expect_error("frames: -3\n", "line 1", "whole number >= 0");
  expect_error("deskew: 2\n", "line 1", "true or false");
  expect_error("colour: blue\n", "line 1", "one of: red or green");
  expect_error("stage:\n  voxel_m: [1, 2]\n", "line 2", "list of 'name: value' maps");
  expect_error("rounds:\n  - {voxel: 1}\n", "line 2", "unknown parameter 'rounds.0.voxel'");
  expect_error("deskew: true\ndeskew: false\n", "line 2", "given twice");
  expect_error("stage:\n  voxel_m: 0.3\n   bad: [\n", "line 3", "");  // YAML syntax
}

TEST(ConfigFile, DumpListsEveryParameterAndLoadsBack) {
  Small changed;
  changed.stage.voxel_m = 0.1;
  changed.colour = Colour::kGreen;
  changed.name = "say \"hi\"";
  changed.height_m = 2.0;
  changed.rounds = {{3.0, 9}};
  const std::string text = io::dump_config(changed, "header line");
  for (const char* meaning : {"voxel edge, m", "use point times", "frames used", "a label", "red or green", "height, m"}) {
    EXPECT_NE(text.find(std::string("# ") + meaning + "\n"), std::string::npos) << meaning;
  }
  EXPECT_NE(text.find("# header line\n"), std::string::npos);
  EXPECT_NE(text.find("stage:\n  # voxel edge, m\n  voxel_m: 0.1\n"), std::string::npos) << text;
  const Small back = load(text);
  EXPECT_EQ(back.stage.voxel_m, 0.1);
  EXPECT_EQ(back.colour, Colour::kGreen);
  EXPECT_EQ(back.name, changed.name);
  EXPECT_EQ(back.height_m, 2.0);
  ASSERT_EQ(back.rounds.size(), 1u);
  EXPECT_EQ(back.rounds[0].iterations, 9);
  EXPECT_FALSE(load(io::dump_config(Small{}, "")).height_m.has_value());  // null round-trips
}

TEST(ConfigFile, DoublesDumpExactly) {
  for (double v : {0.1, 1.0 / 3.0, 1e-5, 120.0, -2.5e10}) {
    EXPECT_EQ(*io::config_parse_double(io::config_format_double(v)), v);
  }
  EXPECT_EQ(io::config_format_double(2.0), "2.0");
  EXPECT_FALSE(io::config_parse_double("nan").has_value());
}

TEST(ConfigFile, AssignmentFromCommandLine) {
  Small s;
  io::apply_config_assignments({"stage.iterations=12", "rounds.0.iterations=5"}, "--set", s);
  EXPECT_EQ(s.stage.iterations, 12);
  ASSERT_EQ(s.rounds.size(), 1u);
  EXPECT_EQ(s.rounds[0].iterations, 5);
  EXPECT_THROW(io::apply_config_assignments({"stage.iterations"}, "--set", s), InputError);
  EXPECT_THROW(io::apply_config_assignments({"nope=1"}, "--set", s), InputError);
}

TEST(ConfigFile, ToolAssignmentsOverrideTheDefaults) {
  const cli::ToolConfig c = cli::tool_config_with({"sim.lidar_model=vlp16", "z.max_frames_per_fiducial=16"});
  EXPECT_EQ(c.sim.lidar_model, "vlp16");
  EXPECT_EQ(c.calibrate.z.max_frames_per_fiducial, 16u);
  EXPECT_EQ(c.calibrate.refine.max_frames, cli::ToolConfig{}.calibrate.refine.max_frames);
  try {
    cli::tool_config_with({"z.max_frames_per_fiducal=16"});
    ADD_FAILURE() << "a misspelt key was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("z.max_frames_per_fiducial"), std::string::npos) << e.what();
  }
}

// Changes every field of any config: numbers, flags, texts, enums (to the next name), optionals,
// and every item of every list.
struct ChangeEverything {
  template <class T>
  void operator()(std::string_view, T& field, std::string_view) {
    if constexpr (std::is_same_v<T, bool>) {
      field = !field;
    } else if constexpr (std::is_integral_v<T>) {
      field = static_cast<T>(field + 3);
    } else if constexpr (std::is_floating_point_v<T>) {
      field = field * 1.5 + 0.25;
    } else if constexpr (std::is_same_v<T, std::optional<double>>) {
      field = field ? *field + 1.0 : 0.75;
    } else if constexpr (std::is_same_v<T, std::string>) {
      field += "-x";
    } else {
      const auto names = enum_names(T{});
      for (std::size_t i = 0; i < names.size(); ++i) {
        if (names[i].first == field) {
          field = names[(i + 1) % names.size()].first;
          break;
        }
      }
    }
  }
  template <class S>
  void section(std::string_view, S& sub) {
    visit_config(*this, sub);
  }
  template <class S>
  void list(std::string_view, std::vector<S>& items, std::string_view) {
    for (S& item : items) visit_config(*this, item);
  }
};

TEST(ConfigFile, EveryToolFieldChangedDumpsAndLoadsBackFromAFile) {
  const std::vector<std::string> keys = cli::tool_config_keys();
  EXPECT_EQ(std::set<std::string>(keys.begin(), keys.end()).size(), keys.size()) << "duplicate keys";
  EXPECT_GT(keys.size(), 100u);
  cli::ToolConfig changed;
  ChangeEverything change;
  visit_config(change, changed);
  const std::string dump_default = cli::dump_tool_config({});
  const std::string dump_changed = cli::dump_tool_config(changed);
  const auto path = std::filesystem::temp_directory_path() / ("insalign_cfg_" + std::to_string(::getpid()) + ".yaml");
  { std::ofstream(path) << dump_changed; }
  const cli::ToolConfig back = cli::load_tool_config(path);
  EXPECT_EQ(cli::dump_tool_config(back), dump_changed);
  // Every value line differs from the defaults' (so every field was reached and written).
  std::istringstream a(dump_default), b(dump_changed);
  std::string la, lb;
  int values = 0, same = 0;
  while (std::getline(a, la) && std::getline(b, lb)) {
    if (la.empty() || la.find('#') != std::string::npos || la.back() == ':') continue;
    ++values;
    if (la == lb) {
      ++same;
      ADD_FAILURE() << "unchanged: " << la;
    }
  }
  EXPECT_GE(values, static_cast<int>(keys.size()));
  EXPECT_EQ(same, 0);
  std::filesystem::remove(path);
}

TEST(ConfigFile, ToolKeysAreTheStructPathsAndErrorsNameTheLine) {
  const auto path = std::filesystem::temp_directory_path() / ("insalign_cfg2_" + std::to_string(::getpid()) + ".yaml");
  { std::ofstream(path) << "rough:\n  filter:\n    max_range_m: 60\nrefine:\n  method: occupancy-grid\n  max_frames: 40\n"; }
  const cli::ToolConfig changed = cli::load_tool_config(path);
  EXPECT_EQ(changed.calibrate.rough.filter.max_range_m, 60.0);
  EXPECT_EQ(changed.calibrate.refine.method, RefineMethod::kOccupancyGrid);
  EXPECT_EQ(changed.calibrate.refine.max_frames, 40u);
  { std::ofstream(path) << "rough:\n  max_range: 60\n"; }
  try {
    cli::load_tool_config(path);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), path.string());
    EXPECT_EQ(e.location(), "line 2");
  }
  std::filesystem::remove(path);
}

}  // namespace
}  // namespace insalign
