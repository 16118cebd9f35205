#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <set>

#include "core/errors.hpp"
#include "io/config_file.hpp"

namespace insalign::io {
namespace {

enum class Colour { kRed, kGreen };
struct Inner {
  double voxel_m = 0.5;
  int iterations = 4;
};
struct Small {
  Inner stage;
  bool deskew = true;
  std::size_t frames = 100;
  std::string name = "a b";
  Colour colour = Colour::kRed;
  std::optional<double> height_m;
};

const std::vector<ConfigParam<Small>>& small_params() {
  static const std::vector<ConfigParam<Small>> table = {
      config_field<Small>("stage.voxel_m", "voxel edge, m", [](auto& c) -> auto& { return c.stage.voxel_m; }),
      config_field<Small>("stage.iterations", "iterations", [](auto& c) -> auto& { return c.stage.iterations; }),
      config_field<Small>("deskew", "use point times", [](auto& c) -> auto& { return c.deskew; }),
      config_field<Small>("frames", "frames used", [](auto& c) -> auto& { return c.frames; }),
      config_field<Small>("name", "a label", [](auto& c) -> auto& { return c.name; }),
      config_enum<Small>("colour", "red or green", [](auto& c) -> auto& { return c.colour; },
                         std::vector<std::pair<std::string, Colour>>{{"red", Colour::kRed}, {"green", Colour::kGreen}}),
      config_field<Small>("height_m", "height, m", [](auto& c) -> auto& { return c.height_m; }),
  };
  return table;
}

Small load(const std::string& yaml) {
  Small s;
  apply_config(small_params(), parse_config_scalars(yaml, "test.yaml"), "test.yaml", s);
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
  const Small t = load("deskew: no\nframes: 7\nname: \"12\"\nstage: {iterations: 9}\n");
  EXPECT_FALSE(t.deskew);
  EXPECT_EQ(t.frames, 7u);
  EXPECT_EQ(t.name, "12");
  EXPECT_EQ(t.stage.iterations, 9);
  EXPECT_EQ(load("").stage.voxel_m, 0.5);  // empty file: defaults
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
  expect_error("colour: blue\n", "line 1", "one of: red, green");
  expect_error("stage:\n  voxel_m: [1, 2]\n", "line 2", "single value");
  expect_error("deskew: true\ndeskew: false\n", "line 2", "given twice");
  expect_error("stage:\n  voxel_m: 0.3\n   bad: [\n", "line 3", "");  // YAML syntax
}

TEST(ConfigFile, DumpListsEveryParameterAndLoadsBack) {
  Small changed;
  changed.stage.voxel_m = 0.1;
  changed.colour = Colour::kGreen;
  changed.name = "say \"hi\"";
  changed.height_m = 2.0;
  const std::string text = dump_config(small_params(), changed, "header line");
  for (const auto& p : small_params()) {
    EXPECT_NE(text.find("# " + p.meaning + "\n"), std::string::npos) << p.key;
  }
  EXPECT_NE(text.find("# header line\n"), std::string::npos);
  EXPECT_NE(text.find("stage:\n  # voxel edge, m\n  voxel_m: 0.1\n"), std::string::npos) << text;
  const Small back = load(text);
  EXPECT_EQ(back.stage.voxel_m, 0.1);
  EXPECT_EQ(back.colour, Colour::kGreen);
  EXPECT_EQ(back.name, changed.name);
  EXPECT_EQ(back.height_m, 2.0);
  EXPECT_FALSE(load(dump_config(small_params(), Small{}, "")).height_m.has_value());  // null round-trips
}

TEST(ConfigFile, DoublesDumpExactly) {
  for (double v : {0.1, 1.0 / 3.0, 1e-5, 120.0, -2.5e10}) {
    EXPECT_EQ(*config_parse_double(config_format_double(v)), v);
  }
  EXPECT_EQ(config_format_double(2.0), "2.0");
  EXPECT_FALSE(config_parse_double("nan").has_value());
}

TEST(ConfigFile, AssignmentFromCommandLine) {
  Small s;
  apply_config_assignment(small_params(), "stage.iterations=12", "--set", s);
  EXPECT_EQ(s.stage.iterations, 12);
  EXPECT_THROW(apply_config_assignment(small_params(), "stage.iterations", "--set", s), InputError);
  EXPECT_THROW(apply_config_assignment(small_params(), "nope=1", "--set", s), InputError);
}

TEST(ConfigFile, ToolAssignmentsOverrideTheDefaults) {
  const ToolConfig c = tool_config_with({"sim.lidar_model=vlp16", "z.max_frames_per_fiducial=16"});
  EXPECT_EQ(c.sim.lidar_model, "vlp16");
  EXPECT_EQ(c.calibrate.z.max_frames_per_fiducial, 16u);
  EXPECT_EQ(c.calibrate.refine.frames.max_frames, ToolConfig{}.calibrate.refine.frames.max_frames);
  try {
    tool_config_with({"z.max_frames_per_fiducal=16"});
    ADD_FAILURE() << "a misspelt key was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("z.max_frames_per_fiducial"), std::string::npos) << e.what();
  }
}

TEST(ConfigFile, ToolTableDumpsAndReloadsFromAFile) {
  // Every key unique, every meaning present, and the dump of the defaults loads back unchanged.
  std::set<std::string> keys;
  for (const auto& p : tool_config_params()) {
    EXPECT_TRUE(keys.insert(p.key).second) << "duplicate " << p.key;
    EXPECT_FALSE(p.meaning.empty()) << p.key;
  }
  EXPECT_GT(keys.size(), 80u);
  const ToolConfig defaults;
  const std::string dump = dump_tool_config(defaults);
  const auto path = std::filesystem::temp_directory_path() / ("insalign_cfg_" + std::to_string(::getpid()) + ".yaml");
  { std::ofstream(path) << dump; }
  const ToolConfig back = load_tool_config(path);
  EXPECT_EQ(dump_tool_config(back), dump);
  { std::ofstream(path) << "rough:\n  max_range_m: 60\nrefine:\n  method: occupancy_grid\n  frames:\n    max_frames: 40\n"; }
  const ToolConfig changed = load_tool_config(path);
  EXPECT_EQ(changed.calibrate.rough.max_range_m, 60.0);
  EXPECT_EQ(changed.calibrate.refine.method, RefineMethod::kOccupancyGrid);
  EXPECT_EQ(changed.calibrate.refine.frames.max_frames, 40u);
  EXPECT_EQ(changed.calibrate.refine.frames.min_range_m, defaults.calibrate.refine.frames.min_range_m);
  { std::ofstream(path) << "rough:\n  max_range: 60\n"; }
  try {
    load_tool_config(path);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), path.string());
    EXPECT_EQ(e.location(), "line 2");
  }
  std::filesystem::remove(path);
}

}  // namespace
}  // namespace insalign::io
